// Density grids of heterogeneous media: the world -> voxel map and the trilinear lookup.
// Conventions (clrender/grids.py holds the reference implementation the tests compare with):
// a grid of nx x ny x nz samples fills voxel space [0, nx] x [0, ny] x [0, nz]; sample (i, j, k)
// sits at the voxel centre (i + 0.5, j + 0.5, k + 0.5), x fastest in memory. The density is
// trilinear between centres, clamped to the outermost samples up to the faces of the box (so a
// constant grid is constant inside its box, and a 1x1x1 grid is a homogeneous box), and 0
// outside the box. The medium's coefficients are per unit density: sigma(x) = density(x) sigma;
// with an albedo grid, sigma_t(x) = density(x) sigma_t is split by the albedo there instead.
#ifndef CLRENDER_GRID_H
#define CLRENDER_GRID_H
#include "scene.h"
#include "media/medium_record.h"

// World point -> voxel coordinates (the affine map of Medium.to_voxel).
float3 world_to_voxel(__global const Medium* m, float3 p) {
    return (float3)(dot(m->to_voxel[0].xyz, p) + m->to_voxel[0].w,
                    dot(m->to_voxel[1].xyz, p) + m->to_voxel[1].w,
                    dot(m->to_voxel[2].xyz, p) + m->to_voxel[2].w);
}

// World direction -> voxel space, not normalised: origin + t * dir keeps t in world units.
float3 world_to_voxel_dir(__global const Medium* m, float3 d) {
    return (float3)(dot(m->to_voxel[0].xyz, d), dot(m->to_voxel[1].xyz, d), dot(m->to_voxel[2].xyz, d));
}

// The trilinear lookup at voxel coordinates v of an n grid: the two samples per axis (clamped to
// the grid) and the fractions between them.
typedef struct {
    int3 i0, i1;
    float3 f;
} TrilinearCell;

TrilinearCell trilinear_cell(float3 v, int3 n) {
    float3 u = v - 0.5f;
    float3 base = floor(u);
    TrilinearCell c;
    c.f = u - base;
    int3 i = convert_int3(base);
    c.i0 = clamp(i, (int3)(0), n - 1);
    c.i1 = clamp(i + 1, (int3)(0), n - 1);
    return c;
}

// Trilinear density at voxel coordinates v (8 voxel reads; no transcendental functions).
float grid_density(const Scene* scene, __global const Medium* m, float3 v) {
    int3 n = medium_resolution(m);
    float3 size = convert_float3(n);
    // Written so that NaN coordinates also count as outside.
    if (!(v.x >= 0.0f && v.y >= 0.0f && v.z >= 0.0f && v.x <= size.x && v.y <= size.y && v.z <= size.z))
        return 0.0f;
    TrilinearCell c = trilinear_cell(v, n);
    int3 i0 = c.i0, i1 = c.i1;
    float3 f = c.f;
    __global const float* g = scene->grid_data + medium_voxel_offset(m);
    int row0 = i0.y * n.x, row1 = i1.y * n.x;
    int slice0 = i0.z * n.x * n.y, slice1 = i1.z * n.x * n.y;
    float c00 = mix(g[slice0 + row0 + i0.x], g[slice0 + row0 + i1.x], f.x);
    float c10 = mix(g[slice0 + row1 + i0.x], g[slice0 + row1 + i1.x], f.x);
    float c01 = mix(g[slice1 + row0 + i0.x], g[slice1 + row0 + i1.x], f.x);
    float c11 = mix(g[slice1 + row1 + i0.x], g[slice1 + row1 + i1.x], f.x);
    return mix(mix(c00, c10, f.y), mix(c01, c11, f.y), f.z);
}

// One sample of the albedo grid: RGB, or one channel for all three.
float3 albedo_sample(__global const float* g, int index, int channels) {
    return channels == 3 ? vload3(index, g) : (float3)(g[index]);
}

// The single-scattering albedo of a medium with an albedo grid at voxel coordinates v of its
// density grid: the albedo grid fills the same unit cube at its own resolution, trilinear and
// clamped alike (a point outside the box takes the nearest face's value; the density is 0 there).
float3 grid_albedo(const Scene* scene, __global const Medium* m, float3 v) {
    int3 n = medium_albedo_resolution(m);
    float3 size = convert_float3(n);
    v = clamp(v * (size / convert_float3(medium_resolution(m))), (float3)(0.0f), size);
    TrilinearCell c = trilinear_cell(v, n);
    int channels = medium_albedo_channels(m);
    __global const float* g = scene->grid_data + medium_albedo_offset(m);
    int row0 = c.i0.y * n.x, row1 = c.i1.y * n.x;
    int slice0 = c.i0.z * n.x * n.y, slice1 = c.i1.z * n.x * n.y;
    float3 c00 = mix(albedo_sample(g, slice0 + row0 + c.i0.x, channels), albedo_sample(g, slice0 + row0 + c.i1.x, channels), c.f.x);
    float3 c10 = mix(albedo_sample(g, slice0 + row1 + c.i0.x, channels), albedo_sample(g, slice0 + row1 + c.i1.x, channels), c.f.x);
    float3 c01 = mix(albedo_sample(g, slice1 + row0 + c.i0.x, channels), albedo_sample(g, slice1 + row0 + c.i1.x, channels), c.f.x);
    float3 c11 = mix(albedo_sample(g, slice1 + row1 + c.i0.x, channels), albedo_sample(g, slice1 + row1 + c.i1.x, channels), c.f.x);
    return mix(mix(c00, c10, c.f.y), mix(c01, c11, c.f.y), c.f.z);
}

// The coefficients sigma_a and sigma_s at a point of density `density` and voxel coordinates v:
// the medium's per unit density, or sigma_t split by the albedo grid there.
void grid_coefficients(const Scene* scene, __global const Medium* m, float3 v, float density,
                       float3* sigma_a, float3* sigma_s) {
    if (!medium_has_albedo_grid(m)) {
        *sigma_a = density * medium_sigma_a(m);
        *sigma_s = density * medium_sigma_s(m);
        return;
    }
    float3 sigma_t = density * medium_sigma_t(m);
    *sigma_s = sigma_t * grid_albedo(scene, m, v);
    *sigma_a = sigma_t - *sigma_s;
}

#endif
