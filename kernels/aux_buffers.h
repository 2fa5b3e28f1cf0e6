// Auxiliary per-pixel buffers: the first surface seen through the pixel centre. Written once per
// render (by the launch holding sample 0) and read by the host for ink outlines (outlines.py);
// also the source of the depth and object_id AOVs (clrender/aovs.py). The centre ray makes them
// deterministic: independent of the seed, the sample count and how samples are split into
// launches, and never a blend of two surfaces (an object id cannot be averaged).
#ifndef CLRENDER_AUX_BUFFERS_H
#define CLRENDER_AUX_BUFFERS_H
#include "camera.h"
#include "scene.h"

// What the pixel centres of the lanes' pixels (x, y) see: geometry xyz the unit shading normal
// facing the camera (world space), w the planar depth (distance along the camera axis: 1 / depth
// is affine in the image over a plane, which the outline pass uses to tell a slope from a jump);
// all 0 where the ray escapes. object: the shape index of the hit (TriangleInfo.info.y), -1 where
// the ray escapes.
typedef struct { lane_float3 normal; lane_float depth; lane_int object; } AuxRecord;

AuxRecord aux_record(const Scene* scene, lane_int x, int y) {
    __constant Camera* camera = &scene->params->camera;
    Ray ray = camera_ray(camera, x, y, scene->params->frame.x, scene->params->frame.y,
                         make_lane_float2((lane_float)(0.5f), (lane_float)(0.5f)));
    AuxRecord record = {l3_splat(0.0f), 0.0f, -1};
    LaneHit hit;
    lane_int found = closest_hits(scene, ray.origin, ray.direction, INFINITY, LANE_TRUE, &hit);
    if (lane_any(found)) {
        SurfacePoint sp = surface_point(scene, &hit, ray.direction);
        record.normal = l3_select(record.normal, sp.ns, found);
        record.depth = select(record.depth, l3_dot(l3_sub(sp.p, ray.origin), l3_uniform(camera->forward.xyz)), found);
        record.object = select(record.object, sp.object, found);
    }
    return record;
}

#if LANES == 1
// The record of pixel (x, y), at `slot` in this tile's buffers.
void write_aux(const Scene* scene, int x, int y, int slot, __global float4* aux_geometry,
               __global int* aux_object) {
    AuxRecord record = aux_record(scene, x, y);
    aux_geometry[slot] = (float4)(record.normal, record.depth);
    aux_object[slot] = record.object;
}
#endif

#endif
