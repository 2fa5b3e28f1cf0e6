// Auxiliary per-pixel buffers: the first surface seen through the pixel centre. Written once per
// render (by the launch holding sample 0) and read by the host for ink outlines (outlines.py);
// also the source of the depth and object_id AOVs (clrender/aovs.py). The centre ray makes them
// deterministic: independent of the seed, the sample count and how samples are split into
// launches, and never a blend of two surfaces (an object id cannot be averaged).
#ifndef CLRENDER_AUX_BUFFERS_H
#define CLRENDER_AUX_BUFFERS_H
#include "camera.h"
#include "scene.h"

// geometry: xyz the unit shading normal facing the camera (world space), w the planar depth
// (distance along the camera axis: 1 / depth is affine in the image over a plane, which the
// outline pass uses to tell a slope from a jump); all 0 where the ray escapes.
// object: the shape index of the hit (TriangleInfo.info.y), -1 where the ray escapes.
// (x, y) is the pixel in the full image, `slot` its index in this tile's buffers.
void write_aux(const Scene* scene, int x, int y, int slot, __global float4* aux_geometry,
               __global int* aux_object) {
    __constant Camera* camera = &scene->params->camera;
    Ray ray = camera_ray(camera, x, y, scene->params->frame.x, scene->params->frame.y,
                         (float2)(0.5f, 0.5f));
    float4 geometry = (float4)(0.0f);
    int object = -1;
    Hit hit;
    if (intersect_scene(scene, ray.origin, ray.direction, INFINITY, &hit)) {
        SurfacePoint sp = surface_point(scene, &hit, ray.direction);
        geometry = (float4)(sp.ns, dot(sp.p - ray.origin, camera->forward.xyz));
        object = sp.object;
    }
    aux_geometry[slot] = geometry;
    aux_object[slot] = object;
}

#endif
