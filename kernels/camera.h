// Pinhole camera with a box pixel filter.
#ifndef CLRENDER_CAMERA_H
#define CLRENDER_CAMERA_H
#include "lanes.h"
#include "types.h"

typedef struct { lane_float3 origin; lane_float3 direction; } Ray;

// The ray through pixel (x, y) of the full image, at jitter in [0, 1)^2 within the pixel; per
// lane, the lanes' pixels x of one row y.
Ray camera_ray(__constant Camera* camera, lane_int x, int y, int width, int height, lane_float2 jitter) {
    lane_float sx = 2.0f * (lane_int_to_float(x) + jitter.x) / (float)width - 1.0f;
    lane_float sy = 1.0f - 2.0f * ((float)y + jitter.y) / (float)height;
    Ray ray;
    ray.origin = l3_uniform(camera->origin.xyz);
    ray.direction = l3_normalize(l3_madd(l3_uniform(camera->up.xyz), sy,
                                         l3_madd(l3_uniform(camera->right.xyz), sx, l3_uniform(camera->forward.xyz))));
    return ray;
}

#endif
