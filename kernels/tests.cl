// Small kernels that expose device functions to the Python tests (tests/). Not used to render.
#include "portability.h"
#include "types.h"
#include "math.h"
#include "rng.h"
#include "sampling.h"
#include "camera.h"
#include "bvh.h"
#include "scene.h"
#include "lights.h"
#include "materials/bsdf.h"
#include "media/phase.h"
#include "media/medium.h"
#include "textures/texture.h"
#include "materials/textured_params.h"
#include "materials/shading_maps.h"

// ----- struct layout: sizeof and field offsets, computed from addresses (portable) ----------
#define OFFSET(base, field) ((int)((__global char*)&(base)->field - (__global char*)(base)))

KERNEL void struct_layout(__global WideBvhNode* node, __global TriangleBlock* block, __global Sphere* sphere,
                          __global TriangleShading* sh, __global TriangleInfo* info,
                          __global Material* m, __global Texture* t, __global Emitter* e,
                          __global Medium* md, __global Camera* c, __global Filter* f,
                          __global RenderParams* p, __global AovSums* a, __global GuideLobe* g,
                          __global int* out) {
    int k = 0;
    out[k++] = sizeof(WideBvhNode);
    out[k++] = OFFSET(node, lo_x); out[k++] = OFFSET(node, hi_x); out[k++] = OFFSET(node, lo_y);
    out[k++] = OFFSET(node, hi_y); out[k++] = OFFSET(node, lo_z); out[k++] = OFFSET(node, hi_z);
    out[k++] = OFFSET(node, child); out[k++] = OFFSET(node, count);
    out[k++] = sizeof(TriangleBlock);
    out[k++] = OFFSET(block, v0_x); out[k++] = OFFSET(block, v0_y); out[k++] = OFFSET(block, v0_z);
    out[k++] = OFFSET(block, e1_x); out[k++] = OFFSET(block, e1_y); out[k++] = OFFSET(block, e1_z);
    out[k++] = OFFSET(block, e2_x); out[k++] = OFFSET(block, e2_y); out[k++] = OFFSET(block, e2_z);
    out[k++] = OFFSET(block, slot);
    out[k++] = sizeof(Sphere);
    out[k++] = OFFSET(sphere, centre_radius); out[k++] = OFFSET(sphere, x_axis); out[k++] = OFFSET(sphere, z_axis);
    out[k++] = sizeof(TriangleShading);
    out[k++] = OFFSET(sh, normals);
    out[k++] = sizeof(TriangleInfo);
    out[k++] = OFFSET(info, info);
    out[k++] = sizeof(Material);
    out[k++] = OFFSET(m, kind); out[k++] = OFFSET(m, maps); out[k++] = OFFSET(m, emission);
    out[k++] = OFFSET(m, slot);
    out[k++] = sizeof(Texture);
    out[k++] = OFFSET(t, info); out[k++] = OFFSET(t, format); out[k++] = OFFSET(t, to_uv_u);
    out[k++] = OFFSET(t, to_uv_v); out[k++] = OFFSET(t, color0); out[k++] = OFFSET(t, color1);
    out[k++] = sizeof(Emitter);
    out[k++] = OFFSET(e, kind); out[k++] = OFFSET(e, radiance); out[k++] = OFFSET(e, p0);
    out[k++] = OFFSET(e, e1); out[k++] = OFFSET(e, e2);
    out[k++] = sizeof(Medium);
    out[k++] = OFFSET(md, sigma_a); out[k++] = OFFSET(md, sigma_s); out[k++] = OFFSET(md, params);
    out[k++] = OFFSET(md, grid); out[k++] = OFFSET(md, resolution);
    out[k++] = OFFSET(md, majorant_resolution); out[k++] = OFFSET(md, to_voxel);
    out[k++] = OFFSET(md, albedo_grid); out[k++] = OFFSET(md, albedo_resolution);
    out[k++] = sizeof(Camera);
    out[k++] = OFFSET(c, origin); out[k++] = OFFSET(c, forward); out[k++] = OFFSET(c, right);
    out[k++] = OFFSET(c, up); out[k++] = OFFSET(c, lens);
    out[k++] = sizeof(Filter);
    out[k++] = OFFSET(f, kind); out[k++] = OFFSET(f, support); out[k++] = OFFSET(f, shape);
    out[k++] = OFFSET(f, cells); out[k++] = OFFSET(f, edge_cdf);
    out[k++] = OFFSET(f, edge_mass);
    out[k++] = sizeof(RenderParams);
    out[k++] = OFFSET(p, camera); out[k++] = OFFSET(p, frame); out[k++] = OFFSET(p, config);
    out[k++] = OFFSET(p, environment); out[k++] = OFFSET(p, env_lookup); out[k++] = OFFSET(p, env_to_map);
    out[k++] = OFFSET(p, media); out[k++] = OFFSET(p, volume);
    out[k++] = OFFSET(p, scene_sphere); out[k++] = OFFSET(p, lights); out[k++] = OFFSET(p, tile); out[k++] = OFFSET(p, splat);
    out[k++] = OFFSET(p, splat_reach);
    out[k++] = OFFSET(p, sampling); out[k++] = OFFSET(p, filter); out[k++] = OFFSET(p, light_paths);
    out[k++] = OFFSET(p, guide_grid); out[k++] = OFFSET(p, guide_cells); out[k++] = OFFSET(p, guide_cone);
    out[k++] = sizeof(AovSums);
    out[k++] = OFFSET(a, albedo); out[k++] = OFFSET(a, normal); out[k++] = OFFSET(a, emission);
    out[k++] = OFFSET(a, colour_m2);
    out[k++] = sizeof(GuideLobe);
    out[k++] = OFFSET(g, direction);
}

// ----- BVH: closest hit per ray (over the primitive slots: triangles and spheres) -----------
KERNEL void trace_rays(__global const WideBvhNode* nodes, __global const TriangleBlock* blocks,
                       __global const Sphere* spheres,
                       __global const float4* origins, __global const float4* directions,
                       __global float* hit_t, __global int* hit_prim, __global int* any_hit) {
    int i = get_global_id(0);
    Hit hit;
    hit.t = INFINITY;
    hit.prim = -1;
    traverse_bvh(nodes, blocks, spheres, origins[i].xyz, directions[i].xyz, false, &hit);
    hit_t[i] = hit.t;
    hit_prim[i] = hit.prim;
    Hit shadow;
    shadow.t = INFINITY;
    shadow.prim = -1;
    any_hit[i] = traverse_bvh(nodes, blocks, spheres, origins[i].xyz, directions[i].xyz, true, &shadow);
}

// ----- camera-path samplers (rng.h): `dims` draws of sample i of pixel j --------------------
// out[(j * samples + i) * dims + d]: rng_float2 (xy) and, from a fresh stream, rng_float (z).
KERNEL void path_samples(int sampler, uint seed, int samples, int dims, __global float4* out) {
    int i = get_global_id(0), j = get_global_id(1);
    Rng pairs = rng_for_path((uint)j, (uint)i, seed, sampler);
    Rng singles = rng_for_path((uint)j, (uint)i, seed, sampler);
    for (int d = 0; d < dims; ++d) {
        float2 u = rng_float2(&pairs);
        out[(j * samples + i) * dims + d] = (float4)(u, rng_float(&singles), 0.0f);
    }
}

// ----- a path vertex's numbers (rng.h): draw_vertex_numbers after a first draw, then the same
// three draws one at a time from a copy; out[8 k ..]: the six pairs, then both counters. --------
KERNEL void vertex_numbers(int sampler, uint seed, int samples, __global float2* out) {
    int i = get_global_id(0), j = get_global_id(1);
    Rng together = rng_for_path((uint)j, (uint)i, seed, sampler);
    rng_float2(&together);
    Rng apart = together;
    VertexNumbers n = draw_vertex_numbers(&together);
    __global float2* o = out + (j * samples + i) * 8;
    o[0] = n.light; o[1] = n.direction; o[2] = n.choice;
    o[3] = rng_float2(&apart); o[4] = rng_float2(&apart); o[5] = rng_float2(&apart);
    o[6] = (float2)((float)together.counter, (float)apart.counter);
    o[7] = (float2)(0.0f);
}

// ----- pixel filter (filter.h): the offset and weight of sample i of pixel `pixel` of `size` --
KERNEL void filter_samples(__constant Filter* filter, int pixel, int size, uint seed, __global float2* out) {
    int i = get_global_id(0);
    Rng rng = rng_for_sample((uint)i, 0u, seed);
    float weight;
    float t = sample_filter_axis(filter, rng_float(&rng), pixel, size, &weight);
    out[i] = (float2)(t, weight);
}

// ----- camera rays (camera.h): sample i = (image x, y in pixels from the top-left corner, lens
// u.x, u.y); out[2 i] the ray's origin, out[2 i + 1] its direction. ------------------------
KERNEL void camera_rays(__constant RenderParams* params, __global const float4* samples, __global float4* out) {
    int i = get_global_id(0);
    float4 sample = samples[i];
    int x = (int)floor(sample.x), y = (int)floor(sample.y);
    Ray ray = camera_ray(&params->camera, x, y, params->frame.x, params->frame.y,
                         (float2)(sample.x - (float)x, sample.y - (float)y));
    if (params->camera.lens.x > 0.0f) ray = through_lens(&params->camera, ray, sample.zw);
    out[2 * i] = (float4)(ray.origin, 0.0f);
    out[2 * i + 1] = (float4)(ray.direction, 0.0f);
}

// The scrambled Sobol bits of (index, seed): Owen-scrambled dimensions 0 and 1, the nested
// uniform scramble of the index, against a reference with the generator matrices.
KERNEL void owen_sobol_bits(__global const uint* index, __global const uint* seed, __global uint4* out) {
    int i = get_global_id(0);
    out[i] = (uint4)(owen_sobol0(index[i], seed[i]), owen_sobol1(index[i], seed[i]),
                     nested_uniform_scramble(index[i], seed[i]), reverse_bits(index[i]));
}

// ----- sampling routines: directions and their pdfs, for chi-square tests -------------------
KERNEL void sample_directions(int routine, float g, uint seed, __global float4* out) {
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

// ----- point, spot and directional lights: what emitter 0 sends to points[i] ----------------
// out: (arriving radiance, the distance to the light; -1 where delta_light_sample declines).
KERNEL void delta_light_values(__global const Emitter* emitters, __global const float4* points, __global float4* out) {
    int i = get_global_id(0);
    LightSample ls;
    out[i] = delta_light_sample(emitters, points[i].xyz, 1.0f, &ls) ? (float4)(ls.radiance, ls.dist) : (float4)(-1.0f);
}

// ----- area emitters: one light sample of emitter 0 (the only one) from points[i] -----------
// out_sample: (wi, pdf_w); out_point: (the sampled point q, its distance); out_pdf: x the pdf that
// area_emitter_pdf_w gives for reaching q from the point (the MIS weight's), y the cosine at q.
KERNEL void sample_area_emitter(__global const Emitter* emitters, __global const float* emitter_cdf,
                                __constant RenderParams* params, __global const float4* points,
                                uint seed, __global float4* out_sample, __global float4* out_point,
                                __global float2* out_pdf) {
    int i = get_global_id(0);
    Scene scene;
    scene.params = params;
    scene.emitters = emitters;
    scene.emitter_cdf = emitter_cdf;
    Rng rng = rng_for_sample((uint)i, 3u, seed);
    float3 p = points[i].xyz;
    LightSample ls = sample_light(&scene, p, rng_float2(&rng));
    float3 q = p + ls.dist * ls.wi;
    float3 n = normalize(q - emitters->p0.xyz);
    float cos_light = -dot(ls.wi, emitters->p0.w < 0.0f ? -n : n);
    out_sample[i] = (float4)(ls.wi, ls.pdf_w);
    out_point[i] = (float4)(q, ls.dist);
    out_pdf[i] = (float2)(area_emitter_pdf_w(emitters, 0, p, q, cos_light), cos_light);
}

#if ENVIRONMENT == ENVIRONMENT_IMAGE
KERNEL void sample_environment(__constant RenderParams* params, __global const float4* texels,
                               __global const float* env_cdf, uint seed,
                               __global float4* out, __global float4* radiance, __global float4* looked_up) {
    int i = get_global_id(0);
    Scene scene;
    scene.params = params;
    scene.env_texels = texels;
    scene.env_cdf = env_cdf;
    Rng rng = rng_for_sample((uint)i, 0u, seed);
    float pdf_w;
    float2 uv;
    float3 d = sample_environment_direction(&scene, rng_float2(&rng), &pdf_w, &uv);
    out[i] = (float4)(d, pdf_w);
    radiance[i] = (float4)(environment_radiance_at(&scene, uv), 0.0f);
    // what a BSDF sample finding d would see: the MIS weight needs the same pdf
    float looked_up_pdf_w;
    looked_up[i] = (float4)(environment_radiance_pdf_w(&scene, d, &looked_up_pdf_w), looked_up_pdf_w);
}
#endif

// ----- materials: the BSDF dispatch at a surface point whose normals are +z ----------------
// front_face: whether wo is on the side the surface's winding faces (entering a dielectric).
SurfacePoint test_surface_point(int front_face, float3 ns) {
    SurfacePoint sp;
    sp.p = (float3)(0.0f);
    sp.ng = (float3)(0.0f, 0.0f, 1.0f);
    sp.ns = normalize(ns);
    sp.p_error = 0.0f;
    sp.front_face = front_face != 0;
    sp.material = 0;
    sp.object = 0;
    sp.emitter = -1;
#if TEXTURES
    // uv along x: the tangent of anisotropic lobes (Mitsuba's s) is x projected onto ns's plane.
    sp.uv = (float2)(0.0f);
    sp.dpdu = (float3)(1.0f, 0.0f, 0.0f);
    sp.dpdv = (float3)(0.0f, 1.0f, 0.0f);
#endif
    return sp;
}

// The RenderParams of the BSDF kernels below (and shading_map_values): all zero (no caustic guide: diffuse sampling by the cosine).
__constant RenderParams BSDF_TEST_PARAMS = {0};

// One sample of sample_bsdf per work-item, for wo[i]: (wi, pdf_w) and (weight, eta * (delta ? -1 : 1)).
// albedo: the material's energy-compensation tables (or one unused float).
KERNEL void sample_bsdf_values(__global const Material* material, __global const float* albedo,
                               int front_face, float4 ns, __global const float4* wo, uint seed,
                               __global float4* out_wi, __global float4* out_weight) {
    int i = get_global_id(0);
    Material m = *material;
    Scene scene;
    scene.params = &BSDF_TEST_PARAMS;
    scene.specular_albedo = albedo;
    SurfacePoint sp = test_surface_point(front_face, ns.xyz);
    Rng rng = rng_for_sample((uint)i, 1u, seed);
    BsdfSample bs = sample_bsdf(&scene, &m, &sp, wo[i].xyz, &rng);
    out_wi[i] = (float4)(bs.wi, bs.pdf_w);
    out_weight[i] = (float4)(bs.weight, bs.delta ? -bs.eta : bs.eta);
}

// eval_bsdf (f * |cos|) and sample_bsdf_pdf for pairs (wo[i], wi[i]).
KERNEL void eval_bsdf_values(__global const Material* material, __global const float* albedo,
                             int front_face, float4 ns, __global const float4* wo,
                             __global const float4* wi, __global float4* out) {
    int i = get_global_id(0);
    Material m = *material;
    Scene scene;
    scene.params = &BSDF_TEST_PARAMS;
    scene.specular_albedo = albedo;
    SurfacePoint sp = test_surface_point(front_face, ns.xyz);
    out[i] = (float4)(eval_bsdf(&scene, &m, &sp, wo[i].xyz, wi[i].xyz),
                      sample_bsdf_pdf(&scene, &m, &sp, wo[i].xyz, wi[i].xyz));
}

// Diffuse sampling at points[i] (normal +z, a scene's RenderParams and caustic guide: guide.h):
// (wi, pdf_w) of one sample, and sample_diffuse_pdf of dirs[i] there (x; yzw 0).
KERNEL void sample_diffuse_values(__constant RenderParams* params, __global const GuideLobe* guide,
                                  __global const float4* points, __global const float4* dirs, uint seed,
                                  __global float4* out_wi, __global float4* out_pdf) {
    int i = get_global_id(0);
    Scene scene;
    scene.params = params;
    scene.guide = guide;
    SurfacePoint sp = test_surface_point(1, (float3)(0.0f, 0.0f, 1.0f));
    sp.p = points[i].xyz;
    Rng rng = rng_for_sample((uint)i, 2u, seed);
    float pdf_w;
    float3 wi = sample_diffuse(&scene, &sp, rng_float2(&rng), &pdf_w);
    out_wi[i] = (float4)(wi, pdf_w);
    out_pdf[i] = (float4)(sample_diffuse_pdf(&scene, &sp, dirs[i].xyz), 0.0f, 0.0f, 0.0f);
}

#if DIELECTRIC
// fresnel_dielectric(cos_i, eta) and refract(wo, +z, eta): (F, wt.xyz), wt = 0 under TIR.
KERNEL void fresnel_refract_values(__global const float2* cos_eta, __global float4* out) {
    int i = get_global_id(0);
    float cos_i = cos_eta[i].x, eta = cos_eta[i].y;
    float3 wo = (float3)(sqrt(fmax(0.0f, 1.0f - cos_i * cos_i)), 0.0f, cos_i);
    float3 wt = (float3)(0.0f);
    if (!refract(wo, (float3)(0.0f, 0.0f, 1.0f), eta, &wt)) wt = (float3)(0.0f);
    // Components spelled out: clang widens a float3 after a scalar with an undefined lane,
    // on which Oclgrind 21.10's uninitialised-value checker crashes (docs/portability.md).
    out[i] = (float4)(fresnel_dielectric(cos_i, eta), wt.x, wt.y, wt.z);
}

// The microfacet model (distribution, masking) of width alpha around +z: D(h), G1(cos_o), the
// visible-normal density of h seen from wo, and G(cos_o, cos of wi[i]).
KERNEL void microfacet_values(float alpha, int distribution, int masking, __global const float4* wo,
                              __global const float4* h, __global const float4* wi, __global float4* out) {
    int i = get_global_id(0);
    float3 n = (float3)(0.0f, 0.0f, 1.0f);
    Microfacet mf = make_microfacet(alpha, distribution, masking);
    out[i] = (float4)(microfacet_d(mf, n, h[i].xyz), microfacet_g1(mf, wo[i].z),
                      sample_microfacet_visible_pdf(mf, n, wo[i].xyz, h[i].xyz),
                      microfacet_g(mf, wo[i].z, wi[i].z));
}

// Visible normals of the distribution sampled for wo[i] with random numbers u[i], and their density.
KERNEL void sample_vndf_values(float alpha, int distribution, __global const float4* wo,
                               __global const float2* u, __global float4* out) {
    int i = get_global_id(0);
    float3 n = (float3)(0.0f, 0.0f, 1.0f);
    Microfacet mf = make_microfacet(alpha, distribution, MASKING_SEPARABLE);
    float3 h = sample_microfacet_visible(mf, n, wo[i].xyz, u[i]);
    out[i] = (float4)(h, sample_microfacet_visible_pdf(mf, n, wo[i].xyz, h));
}

// The slopes of Beckmann's unit-width visible normals seen at cos_theta[i], from u[i].
KERNEL void beckmann_visible_slopes(__global const float* cos_theta, __global const float2* u,
                                    __global float2* out) {
    int i = get_global_id(0);
    out[i] = sample_beckmann_visible_11(cos_theta[i], u[i]);
}
#endif

// ----- shading normals as the kernel unpacks them (scene.h, unpack_normal) ---------------------
KERNEL void unpack_normals(__global const int* packed, __global float4* out) {
    int i = get_global_id(0);
    out[i] = (float4)(unpack_normal(packed[i]), 0.0f);
}

// ----- spawned rays: hit a mesh, leave the hit point in a direction given relative to its ------
// geometric normal (leave.xyz: tangent, bitangent, normal components; the normal component's
// sign picks the side), and report both hits: (first slot, second slot, second t, front face).
KERNEL void spawn_from_hits(__global const WideBvhNode* nodes, __global const TriangleBlock* blocks,
                            __global const Sphere* spheres,
                            __global const TriangleShading* shading,
                            __global const TriangleInfo* info, __global const float2* uvs,
                            __global const float4* origins, __global const float4* directions,
                            __global const float4* leave, __global float4* out) {
    int i = get_global_id(0);
    Scene scene;
    scene.nodes = nodes;
    scene.blocks = blocks;
    scene.spheres = spheres;
    scene.shading = shading;
    scene.info = info;
    scene.uvs = uvs;
    out[i] = (float4)(-1.0f, -1.0f, INFINITY, 0.0f);
    Hit hit;
    if (!intersect_scene(&scene, origins[i].xyz, directions[i].xyz, INFINITY, &hit)) return;
    SurfacePoint sp = surface_point(&scene, &hit, directions[i].xyz);
    float3 t, b;
    make_basis(sp.ng, &t, &b);
    float3 dir = normalize(leave[i].x * t + leave[i].y * b + leave[i].z * sp.ng);
    Hit next;
    bool found = intersect_scene(&scene, spawn_ray_origin(&sp, dir), dir, INFINITY, &next);
    out[i] = (float4)((float)hit.prim, found ? (float)next.prim : -1.0f, next.t,
                      sp.front_face ? 1.0f : 0.0f);
}
#if GRID_MEDIA
// ----- grid media: lookups, majorant walks, transmittance estimators -------------------------
Scene media_scene(__constant RenderParams* params, __global const Medium* media,
                  __global const float* grid_data, __global const float* majorant_data) {
    Scene scene;
    scene.params = params;
    scene.media = media;
    scene.grid_data = grid_data;
    scene.majorant_data = majorant_data;
    return scene;
}

// Density (x) and albedo (yzw; 0 without an albedo grid) of grid medium points[i].w at world
// point points[i].xyz.
KERNEL void grid_lookup(__constant RenderParams* params, __global const Medium* media,
                        __global const float* grid_data, __global const float* majorant_data,
                        __global const float4* points, __global float4* out) {
    int i = get_global_id(0);
    Scene scene = media_scene(params, media, grid_data, majorant_data);
    __global const Medium* m = media + (int)points[i].w;
    float3 v = world_to_voxel(m, points[i].xyz);
    float3 albedo = medium_has_albedo_grid(m) ? grid_albedo(&scene, m, v) : (float3)(0.0f);
    // Lane by lane: Oclgrind's uninitialised-value checker crashes on the shuffle that
    // (float4)(float, float3) makes of a float3's undefined fourth lane.
    out[i] = (float4)(grid_density(&scene, m, v), albedo.x, albedo.y, albedo.z);
}

// The majorant segments of ray i (at most max_segments: (t0, t1, d_max, d_min)), their count,
// and over `samples` jittered points per segment: max(density - d_max), min(density - d_min).
KERNEL void majorant_walk(__constant RenderParams* params, __global const Medium* media,
                          __global const float* grid_data, __global const float* majorant_data,
                          int medium, __global const float4* origins, __global const float4* dirs,
                          float t_max, int max_segments, int samples, uint seed,
                          __global float4* segments, __global int* counts, __global float2* bounds) {
    int i = get_global_id(0);
    Scene scene = media_scene(params, media, grid_data, majorant_data);
    __global const Medium* m = media + medium;
    Rng rng = rng_for_sample((uint)i, 0u, seed);
    MajorantIterator it = majorant_iterator(&scene, m, origins[i].xyz, dirs[i].xyz, t_max);
    MajorantSegment seg;
    int count = 0;
    float2 worst = (float2)(-INFINITY, INFINITY);
    while (majorant_next(&scene, m, &it, &seg)) {
        if (count < max_segments) segments[i * max_segments + count] = (float4)(seg.t0, seg.t1, seg.d_max, seg.d_min);
        ++count;
        for (int k = 0; k < samples; ++k) {
            float t = seg.t0 + (seg.t1 - seg.t0) * ((float)k + rng_float(&rng)) / (float)samples;
            float density = majorant_ray_density(&scene, m, &it, t);
            worst = (float2)(fmax(worst.x, density - seg.d_max), fmin(worst.y, density - seg.d_min));
        }
    }
    counts[i] = count;
    bounds[i] = worst;
}

// One transmittance estimate per work-item along origin + t dir, t in [0, t_max), through one
// medium (media/medium.h's medium_transmittance): xyz the estimate, w the tentative collisions
// of ratio tracking (null scattering through a grid; else 0). `spectral_mis` as
// RenderParams.media.y (ratio tracking only).
KERNEL void transmittance_estimates(__constant RenderParams* params, __global const Medium* media,
                                    __global const float* grid_data, __global const float* majorant_data,
                                    int medium, float4 origin, float4 dir, float t_max, uint seed,
                                    int spectral_mis, __global float4* out) {
    int i = get_global_id(0);
    Scene scene = media_scene(params, media, grid_data, majorant_data);
    Rng rng = rng_for_sample((uint)i, 0u, seed);
    __global const Medium* m = media + medium;
    float pdf_ratio;
    int collisions = 0;
    float3 tr;
#if GRID_MEDIA == VOLUME_NULL
    if (medium_is_grid(m))
        tr = ratio_tracking_transmittance(&scene, m, origin.xyz, dir.xyz, t_max, spectral_mis != 0, &rng,
                                          &pdf_ratio, &collisions);
    else
#endif
        tr = medium_transmittance(&scene, medium, origin.xyz, dir.xyz, t_max, &rng, &pdf_ratio);
    out[i] = (float4)(tr, (float)collisions);
}

#if GRID_MEDIA == VOLUME_NULL
// Delta tracking over one grid-medium segment: the weight when the ray passes (its expectation
// is the transmittance per channel), 0 when it scatters or is absorbed; w the collisions.
KERNEL void delta_pass_estimates(__constant RenderParams* params, __global const Medium* media,
                                 __global const float* grid_data, __global const float* majorant_data,
                                 int medium, float4 origin, float4 dir, float t_max, uint seed,
                                 int spectral_mis, __global float4* out) {
    int i = get_global_id(0);
    Scene scene = media_scene(params, media, grid_data, majorant_data);
    Rng rng = rng_for_sample((uint)i, 0u, seed);
    Ray ray;
    ray.origin = origin.xyz;
    ray.direction = dir.xyz;
    int collisions;
    MediumSample s = delta_tracking_sample(&scene, media + medium, ray, t_max, spectral_mis != 0, &rng,
                                           &collisions);
    out[i] = (float4)(s.event == MEDIUM_EVENT_PASS ? s.weight : (float3)(0.0f), (float)collisions);
}
#endif
#endif

#if TEXTURES
// ----- textures: eval_texture (xyz) and eval_texture_number (w) of texture `index` at uv[i] ------
KERNEL void eval_texture_values(__global const Texture* textures, __global const uchar* texels, int index,
                                __global const float2* uv, __global float4* out) {
    int i = get_global_id(0);
    Scene scene;
    scene.textures = textures;
    scene.texels = texels;
    out[i] = (float4)(eval_texture(&scene, index, uv[i]), eval_texture_number(&scene, index, uv[i]));
}

// eval_texture_number_gradient of texture `index` at uv[i].
KERNEL void texture_gradient_values(__global const Texture* textures, __global const uchar* texels, int index,
                                    __global const float2* uv, __global float2* out) {
    int i = get_global_id(0);
    Scene scene;
    scene.textures = textures;
    scene.texels = texels;
    out[i] = eval_texture_number_gradient(&scene, index, uv[i]);
}

// The BSDF of material 0 under its bump or normal map, at surface points given by frame[5 i ...]:
// (uv, front face, -), the front side's shading and geometric normals, dp/du, dp/dv. For wo[i],
// wi[i]: out_f (eval_bsdf x shading_map_factor, and sample_bsdf_pdf where that factor is not 0, as
// path.h uses it), out_n the bent normal.
KERNEL void shading_map_values(__global const Material* material, __global const Texture* textures,
                               __global const uchar* texels, __global const float4* frame,
                               __global const float4* wo, __global const float4* wi,
                               __global float4* out_f, __global float4* out_n) {
    int i = get_global_id(0);
    Scene scene;
    scene.params = &BSDF_TEST_PARAMS;
    scene.textures = textures;
    scene.texels = texels;
    __global const float4* f = frame + 5 * i;
    bool front = f[0].z != 0.0f;
    SurfacePoint sp = test_surface_point(front, (float3)(0.0f, 0.0f, 1.0f));
    sp.ns = front ? f[1].xyz : -f[1].xyz;
    sp.ng = front ? f[2].xyz : -f[2].xyz;
    sp.uv = f[0].xy;
    sp.dpdu = f[3].xyz;
    sp.dpdv = f[4].xyz;
    Material m = *material;
    bend_shading_normal(&scene, &m, &sp, wo[i].xyz);
    float factor = shading_map_factor(&m, &sp, wi[i].xyz);
    float3 value = eval_bsdf(&scene, &m, &sp, wo[i].xyz, wi[i].xyz) * factor;
    out_f[i] = (float4)(value, factor > 0.0f ? sample_bsdf_pdf(&scene, &m, &sp, wo[i].xyz, wi[i].xyz) : 0.0f);
    out_n[i] = (float4)(sp.ns, 0.0f);
}

// resolve_textured_params on material 0 at uv[i]: every slot's lanes, then the emission's.
KERNEL void resolve_material_values(__global const Material* materials, __global const Texture* textures,
                                    __global const uchar* texels, __global const float2* uv,
                                    __global float4* out) {
    int i = get_global_id(0);
    Scene scene;
    scene.textures = textures;
    scene.texels = texels;
    Material m = materials[0];
    resolve_textured_params(&scene, &m, uv[i]);
    for (int k = 0; k < MATERIAL_SLOTS; ++k) out[i * (MATERIAL_SLOTS + 1) + k] = m.slot[k];
    out[i * (MATERIAL_SLOTS + 1) + MATERIAL_SLOTS] = m.emission;
}
#endif

// ----- a row of filter values (filter.h, filter_row): out[i] the filter at t + i ---------------
KERNEL void filter_row_values(__constant Filter* filter, float t, __global float* out) {
    FilterRow row = filter_row(filter, t);
    for (int i = 0; i < (int)get_global_size(0); ++i) {
        float value = filter_row_next(filter, &row);
        if (i == (int)get_global_id(0)) out[i] = value;
    }
}
