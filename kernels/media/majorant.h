// Majorant iteration: a ray through a medium as segments [t0, t1) of bounded density.
//
// The idea of pbrt-v4's SampleT_maj: one generic walk serves every estimator of grid media
// (media/tracking.h, media/raymarch.h; homogeneous media need none). A grid medium is walked with a
// 3D DDA (Amanatides and Woo 1987) over its coarse majorant grid (clrender/grids.py,
// block_bounds): each block yields a segment with the block's maximum and minimum density, so
// majorants are tight where the cloud is thin, and blocks of zero density are skipped without
// a single density lookup. OpenCL C 1.2 has no lambdas, so instead of a callback the caller
// pulls segments from an iterator:
//
//     MajorantIterator it = majorant_iterator(scene, m, origin, dir, t_max);
//     MajorantSegment seg;
//     while (majorant_next(scene, m, &it, &seg)) { ... seg.t0, seg.t1, seg.d_max, seg.d_min ... }
//
// Distances t are world distances along origin + t * dir (dir need not be normalised).
#ifndef CLRENDER_MAJORANT_H
#define CLRENDER_MAJORANT_H
#include "media/grid.h"

typedef struct {
    float t0, t1;        // the segment of the ray
    float d_max, d_min;  // bounds of the density over it (d_max > 0)
} MajorantSegment;

typedef struct {
    float3 voxel_origin, voxel_dir;  // the ray in voxel coordinates (media/grid.h)
    float3 t_next;       // distance to the next block boundary, per axis
    float3 t_delta;      // distance between block boundaries, per axis
    int3 cell, step, res;
    float t, t_end;      // current distance; end of the ray inside the grid box
    int steps_left;      // DDA steps left: bounds the loop whatever the floating point does
} MajorantIterator;

MajorantIterator majorant_iterator(const Scene* scene, __global const Medium* m, float3 origin,
                                   float3 dir, float t_max) {
    MajorantIterator it;
    it.t = 0.0f;
    it.t_end = t_max;
    it.steps_left = 0;
    it.voxel_origin = world_to_voxel(m, origin);
    it.voxel_dir = world_to_voxel_dir(m, dir);
    float block = (float)medium_majorant_block(m);
    float3 o = it.voxel_origin / block, d = it.voxel_dir / block;   // block coordinates
    float3 box = convert_float3(medium_resolution(m)) / block;         // the grid box [0, box]
    // Slab test. A zero direction component gives infinite inverse: +-inf bounds when the origin
    // is strictly inside the slab (no constraint) or outside it (a miss); NaN (origin exactly on
    // the slab plane) is ignored by fmin/fmax or misses, either of which is consistent.
    float3 inv = 1.0f / d;
    float3 ta = (0.0f - o) * inv, tb = (box - o) * inv;
    float3 t_near = fmin(ta, tb), t_far = fmax(ta, tb);
    float t_enter = fmax(fmax(t_near.x, t_near.y), fmax(t_near.z, 0.0f));
    float t_exit = fmin(fmin(t_far.x, t_far.y), fmin(t_far.z, t_max));
    if (!(t_enter < t_exit)) {
        it.t_end = 0.0f;
        return it;
    }
    it.t = t_enter;
    it.t_end = t_exit;
    it.res = medium_majorant_resolution(m);
    float3 p = o + t_enter * d;
    it.cell = clamp(convert_int3(floor(p)), (int3)(0), it.res - 1);
    float3 cell = convert_float3(it.cell);
    it.step = (int3)(d.x > 0.0f ? 1 : (d.x < 0.0f ? -1 : 0), d.y > 0.0f ? 1 : (d.y < 0.0f ? -1 : 0),
                     d.z > 0.0f ? 1 : (d.z < 0.0f ? -1 : 0));
    float3 boundary = cell + (float3)(it.step.x > 0 ? 1.0f : 0.0f, it.step.y > 0 ? 1.0f : 0.0f,
                                      it.step.z > 0 ? 1.0f : 0.0f);
    it.t_next = (float3)(it.step.x ? (boundary.x - o.x) * inv.x : INFINITY,
                         it.step.y ? (boundary.y - o.y) * inv.y : INFINITY,
                         it.step.z ? (boundary.z - o.z) * inv.z : INFINITY);
    it.t_delta = (float3)(it.step.x ? fabs(inv.x) : INFINITY, it.step.y ? fabs(inv.y) : INFINITY,
                          it.step.z ? fabs(inv.z) : INFINITY);
    it.steps_left = it.res.x + it.res.y + it.res.z + 3;
    return it;
}

// The next segment of positive majorant; false when the ray has left the grid (or t_max).
bool majorant_next(const Scene* scene, __global const Medium* m, MajorantIterator* it,
                   MajorantSegment* seg) {
    __global const float* bounds = scene->majorant_data + 2 * medium_majorant_offset(m);
    while (it->steps_left > 0 && it->t < it->t_end) {
        --it->steps_left;
        float3 tn = it->t_next;
        int axis = (tn.x <= tn.y && tn.x <= tn.z) ? 0 : (tn.y <= tn.z ? 1 : 2);
        float t_exit = fmin(axis == 0 ? tn.x : (axis == 1 ? tn.y : tn.z), it->t_end);
        int index = (it->cell.z * it->res.y + it->cell.y) * it->res.x + it->cell.x;
        float d_max = bounds[2 * index], d_min = bounds[2 * index + 1];
        float t0 = it->t;
        it->t = t_exit;
        // Step into the neighbouring block; leaving the grid ends the walk.
        if (axis == 0) {
            it->cell.x += it->step.x;
            it->t_next.x += it->t_delta.x;
            if (it->cell.x < 0 || it->cell.x >= it->res.x) it->t_end = t_exit;
        } else if (axis == 1) {
            it->cell.y += it->step.y;
            it->t_next.y += it->t_delta.y;
            if (it->cell.y < 0 || it->cell.y >= it->res.y) it->t_end = t_exit;
        } else {
            it->cell.z += it->step.z;
            it->t_next.z += it->t_delta.z;
            if (it->cell.z < 0 || it->cell.z >= it->res.z) it->t_end = t_exit;
        }
        if (d_max > 0.0f && t_exit > t0) {
            seg->t0 = t0;
            seg->t1 = t_exit;
            seg->d_max = d_max;
            seg->d_min = d_min;
            return true;
        }
    }
    return false;
}

// Voxel coordinates of distance t along the iterator's ray.
float3 majorant_ray_voxel(const MajorantIterator* it, float t) { return it->voxel_origin + t * it->voxel_dir; }

// Density at distance t along the iterator's ray.
float majorant_ray_density(const Scene* scene, __global const Medium* m, const MajorantIterator* it,
                           float t) {
    return medium_is_grid(m) ? grid_density(scene, m, majorant_ray_voxel(it, t)) : 1.0f;
}

#endif
