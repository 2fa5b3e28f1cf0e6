// The camera: a pinhole, or a thin lens (Mitsuba's thinlens); a camera sample's image position
// drawn from the pixel filter (filter.h).
#ifndef CLRENDER_CAMERA_H
#define CLRENDER_CAMERA_H
#include "lanes.h"
#include "types.h"
#include "rng.h"
#include "sampling.h"
#include "filter.h"
#include "splat.h"

typedef struct { lane_float3 origin; lane_float3 direction; } Ray;

// The ray through pixel (x, y) of the full image, at `position` relative to the pixel's top-left
// corner ((0.5, 0.5): its centre); per lane, the lanes' pixels x of one row y.
Ray camera_ray(__constant Camera* camera, lane_int x, int y, int width, int height, lane_float2 position) {
    lane_float sx = 2.0f * (lane_int_to_float(x) + position.x) / (float)width - 1.0f;
    lane_float sy = 1.0f - 2.0f * ((float)y + position.y) / (float)height;
    Ray ray;
    ray.origin = l3_uniform(camera->origin.xyz);
    ray.direction = l3_normalize(l3_madd(l3_uniform(camera->up.xyz), sy,
                                         l3_madd(l3_uniform(camera->right.xyz), sx, l3_uniform(camera->forward.xyz))));
    return ray;
}

// Depth of field (Mitsuba's thinlens): the ray from a point of the aperture, a disk of radius
// lens.x around the camera's position across the view (u by the concentric map, in Mitsuba's
// orientation: x to the image's left, y up), towards the point where the pinhole ray meets the
// plane in focus, lens.y along forward. Points on that plane are sharp.
Ray through_lens(__constant Camera* camera, Ray pinhole, lane_float2 u) {
    lane_float along = l3_dot(pinhole.direction, l3_uniform(camera->forward.xyz));
    lane_float3 focus = l3_madd(pinhole.direction, camera->lens.y / along, pinhole.origin);
    lane_float2 disk = sample_concentric_disk(u);
    float3 left = normalize(camera->right.xyz) * -camera->lens.x, up = normalize(camera->up.xyz) * camera->lens.x;
    Ray ray;
    ray.origin = l3_madd(l3_uniform(left), disk.x, l3_madd(l3_uniform(up), disk.y, pinhole.origin));
    ray.direction = l3_normalize(l3_sub(focus, ray.origin));
    return ray;
}

// A camera ray of pixel (x, y), the weight of its radiance in the pixel's mean (the filter's,
// filter.h) and its image position relative to the pixel's top-left corner (what splatting
// weighs, splat.h). It takes the path's first sampler dimension, and with a lens the second.
typedef struct { Ray ray; lane_float weight; lane_float2 position; } CameraSample;

CameraSample sample_camera(__constant RenderParams* params, lane_int x, int y, Rng* rng) {
    int width = params->frame.x, height = params->frame.y;
    CameraSample sample;
    lane_float2 u = rng_float2(rng);
    // Splatting weighs samples taken uniformly in their pixels (splat.h); else the filter places them.
    sample.weight = 1.0f;
    sample.position = SPLATTING(params) ? u : sample_filter(&params->filter, u, x, y, width, height, &sample.weight);
    sample.ray = camera_ray(&params->camera, x, y, width, height, sample.position);
    if (params->camera.lens.x > 0.0f) sample.ray = through_lens(&params->camera, sample.ray, rng_float2(rng));
    return sample;
}

#endif
