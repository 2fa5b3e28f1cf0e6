// Pinhole camera with a box pixel filter.
#ifndef CLRENDER_CAMERA_H
#define CLRENDER_CAMERA_H
#include "types.h"

typedef struct { float3 origin; float3 direction; } Ray;

Ray camera_ray(__constant Camera* camera, int x, int y, int width, int height, float2 jitter) {
    float sx = 2.0f * ((float)x + jitter.x) / (float)width - 1.0f;
    float sy = 1.0f - 2.0f * ((float)y + jitter.y) / (float)height;
    Ray ray;
    ray.origin = camera->origin.xyz;
    ray.direction = normalize(camera->forward.xyz + sx * camera->right.xyz + sy * camera->up.xyz);
    return ray;
}

#endif
