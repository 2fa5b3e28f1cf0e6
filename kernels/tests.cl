// Small kernels that expose device functions to the Python tests (tests/). Not used to render.
#include "types.h"
#include "math.h"
#include "rng.h"
#include "sampling.h"
#include "camera.h"
#include "bvh.h"
#include "scene.h"
#include "lights.h"
#include "media/phase.h"

// ----- struct layout: sizeof and field offsets, computed from addresses (portable) ----------
#define OFFSET(base, field) ((int)((__global char*)&(base)->field - (__global char*)(base)))

__kernel void struct_layout(__global BvhNode* node, __global Triangle* tri,
                            __global TriangleShading* sh, __global TriangleInfo* info,
                            __global Material* m, __global Emitter* e, __global Medium* md,
                            __global Camera* c,
                            __global RenderParams* p, __global int* out) {
    int k = 0;
    out[k++] = sizeof(BvhNode);
    out[k++] = OFFSET(node, left_lo); out[k++] = OFFSET(node, left_hi);
    out[k++] = OFFSET(node, right_lo); out[k++] = OFFSET(node, right_hi);
    out[k++] = sizeof(Triangle);
    out[k++] = OFFSET(tri, v0); out[k++] = OFFSET(tri, e1); out[k++] = OFFSET(tri, e2);
    out[k++] = sizeof(TriangleShading);
    out[k++] = OFFSET(sh, n0); out[k++] = OFFSET(sh, n1); out[k++] = OFFSET(sh, n2);
    out[k++] = sizeof(TriangleInfo);
    out[k++] = OFFSET(info, info);
    out[k++] = sizeof(Material);
    out[k++] = OFFSET(m, kind); out[k++] = OFFSET(m, color); out[k++] = OFFSET(m, emission);
    out[k++] = OFFSET(m, params); out[k++] = OFFSET(m, toon_shadow); out[k++] = OFFSET(m, toon_bands);
    out[k++] = OFFSET(m, toon_highlight); out[k++] = OFFSET(m, toon_rim);
    out[k++] = sizeof(Emitter);
    out[k++] = OFFSET(e, kind); out[k++] = OFFSET(e, radiance); out[k++] = OFFSET(e, p0);
    out[k++] = OFFSET(e, e1); out[k++] = OFFSET(e, e2);
    out[k++] = sizeof(Medium);
    out[k++] = OFFSET(md, sigma_a); out[k++] = OFFSET(md, sigma_s); out[k++] = OFFSET(md, params);
    out[k++] = OFFSET(md, grid); out[k++] = OFFSET(md, resolution);
    out[k++] = OFFSET(md, majorant_resolution); out[k++] = OFFSET(md, to_voxel);
    out[k++] = sizeof(Camera);
    out[k++] = OFFSET(c, origin); out[k++] = OFFSET(c, forward); out[k++] = OFFSET(c, right);
    out[k++] = OFFSET(c, up);
    out[k++] = sizeof(RenderParams);
    out[k++] = OFFSET(p, camera); out[k++] = OFFSET(p, frame); out[k++] = OFFSET(p, config);
    out[k++] = OFFSET(p, environment); out[k++] = OFFSET(p, media); out[k++] = OFFSET(p, volume);
    out[k++] = OFFSET(p, scene_sphere); out[k++] = OFFSET(p, lights);
}

// ----- BVH: closest hit per ray ------------------------------------------------------------
__kernel void trace_rays(__global const BvhNode* nodes, __global const Triangle* triangles,
                         __global const float4* origins, __global const float4* directions,
                         __global float* hit_t, __global int* hit_triangle, __global int* any_hit) {
    int i = get_global_id(0);
    Hit hit;
    hit.t = INFINITY;
    hit.triangle = -1;
    traverse_bvh(nodes, triangles, origins[i].xyz, directions[i].xyz, false, &hit);
    hit_t[i] = hit.t;
    hit_triangle[i] = hit.triangle;
    Hit shadow;
    shadow.t = INFINITY;
    shadow.triangle = -1;
    any_hit[i] = traverse_bvh(nodes, triangles, origins[i].xyz, directions[i].xyz, true, &shadow);
}

// ----- sampling routines: directions and their pdfs, for chi-square tests -------------------
__kernel void sample_directions(int routine, float g, uint seed, __global float4* out) {
    int i = get_global_id(0);
    Rng rng = rng_for_sample((uint)i, 0u, seed);
    float2 u = rng_float2(&rng);
    float3 d;
    float pdf;
    if (routine == 0) {
        d = sample_cosine_hemisphere(u);
        pdf = sample_cosine_hemisphere_pdf_w(d.z);
    } else if (routine == 1) {
        d = sample_uniform_sphere(u);
        pdf = UNIFORM_SPHERE_PDF_W;
    } else {
        d = sample_phase_hg((float3)(0.0f, 0.0f, 1.0f), g, u, &pdf);
    }
    out[i] = (float4)(d, pdf);
}

#if ENVIRONMENT == ENVIRONMENT_IMAGE
__kernel void sample_environment(__constant RenderParams* params, __global const float4* texels,
                                 __global const float* env_cdf, uint seed,
                                 __global float4* out, __global float4* radiance) {
    int i = get_global_id(0);
    Scene scene;
    scene.params = params;
    scene.env_texels = texels;
    scene.env_cdf = env_cdf;
    Rng rng = rng_for_sample((uint)i, 0u, seed);
    float3 d = sample_environment_direction(&scene, rng_float2(&rng));
    out[i] = (float4)(d, environment_pdf_w(&scene, d));
    radiance[i] = (float4)(environment_radiance(&scene, d), 0.0f);
}
#endif
