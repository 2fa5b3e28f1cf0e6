// Photons of the caustic guide (guide.h, clrender/guide.py): light paths from the scene's
// directional lights and emitting triangles, followed through specular and glossy surfaces
// (dielectrics, conductors, thin dielectrics) to the first other surface. Where that is diffuse
// and the path crossed one such surface or more, the photon is a record: (its point, its weight's
// luminance), (the direction it arrived from, its index): light that diffuse sampling finds only
// by chance there. Photon i takes the independent numbers of (i, 0, seed), so the records are the
// same however the launch is split; they are appended at an atomic counter in any order (the host
// sorts them by index) and a count beyond `capacity` means they did not fit.
#include "portability.h"
#include "rng.h"
#include "sampling.h"
#include "scene.h"
#include "lights.h"
#include "materials/material.h"
#include "materials/bsdf.h"
#include "materials/textured_params.h"

#define GUIDE_PHOTON_BOUNCES 16

// The photon's start from emitter `index`: a ray and its weight (flux over the emitter's pmf);
// false for the kinds that give no photons (points, spots, the environment, textured emitters).
// A directional light's photons cross a disk facing it around `target` (the specular shapes'
// bounding sphere), from beyond the scene's bounding sphere.
bool start_guide_photon(const Scene* scene, int index, float pmf, float4 target, float2 u_on, float2 u_dir,
                        float3* origin, float3* dir, float3* weight) {
    __global const Emitter* e = scene->emitters + index;
    if (e->kind.x == EMITTER_DIRECTIONAL) {
        float3 to_light = e->p0.xyz;
        float2 d = sample_concentric_disk(u_on);
        float3 t, b;
        make_basis(to_light, &t, &b);
        float4 sphere = scene->params->scene_sphere;
        float far = length(sphere.xyz - target.xyz) + sphere.w + target.w;
        *origin = target.xyz + target.w * (d.x * t + d.y * b) + far * to_light;
        *dir = -to_light;
        *weight = e->radiance.xyz * (PI_F * target.w * target.w / pmf);
        return true;
    }
    if (e->kind.x != EMITTER_TRIANGLE || e->radiance.w >= 0.0f) return false;
    float3 e1 = e->e1.xyz, e2 = e->e2.xyz;
    float2 bary = sample_triangle(u_on);
    float3 n = normalize(cross(e1, e2));   // the emitting side
    float3 q = e->p0.xyz + bary.x * e1 + bary.y * e2;
    *dir = to_world(sample_cosine_hemisphere(u_dir), n);
    float3 magnitude = fabs(e->p0.xyz) + fabs(e1) + fabs(e2);
    *origin = offset_ray_origin(q, n, SURFACE_ERROR_EPS * dot(fabs(n), magnitude));
    *weight = e->radiance.xyz * (PI_F * e->p0.w / pmf);   // Le cos / (pmf / area x cos / pi)
    return true;
}

void trace_guide_photon(const Scene* scene, int photon, uint seed, float4 target, __global float4* records,
                        __global int* count, int capacity) {
    int emitters = scene->params->config.w;
    if (emitters == 0) return;
    Rng rng = rng_for_sample((uint)photon, 0u, seed);
    float2 u = rng_float2(&rng);
    float u_on;
    int index = sample_discrete_cdf_reuse(scene->emitter_cdf, emitters, u.x, &u_on);
    float3 origin, dir, weight;
    if (!start_guide_photon(scene, index, emitter_selection_pmf(scene, index), target, (float2)(u_on, u.y),
                            rng_float2(&rng), &origin, &dir, &weight))
        return;
    bool crossed = false;   // a specular or glossy surface so far
    for (int bounce = 0; bounce < GUIDE_PHOTON_BOUNCES; ++bounce) {
        Hit hit;
        if (!intersect_scene(scene, origin, dir, INFINITY, &hit)) return;
        SurfacePoint sp = surface_point(scene, &hit, dir);
        Material mat = surface_material(scene, &sp);
        float3 wl = -dir;
        if (!is_specular_material(&mat)) {
            if (!crossed || material_kind(&mat) != MATERIAL_DIFFUSE || !(dot(wl, sp.ng) > 0.0f)) return;
            int slot = atomic_inc(count);
            if (slot >= capacity) return;
            records[2 * slot] = (float4)(sp.p, luminance(weight));
            records[2 * slot + 1] = (float4)(wl, as_float(photon));
            return;
        }
        BsdfSample bs = sample_bsdf(scene, &mat, &sp, wl, &rng);
        if (!(bs.pdf_w > 0.0f) || is_black(bs.weight)) return;
        weight *= bs.weight * (bs.eta * bs.eta);   // importance: no 1 / eta^2 at a refraction
        crossed = true;
        origin = spawn_ray_origin(&sp, bs.wi);
        dir = bs.wi;
    }
}

KERNEL void guide_photons(RENDER_SCENE_ARGUMENTS, float4 target, uint seed, int photons, __global float4* records,
                          __global int* count, int capacity) {
    int i = get_global_id(0);
    if (i >= photons) return;
    Scene scene = SCENE_OF_RENDER_PASS_ARGUMENTS;
    trace_guide_photon(&scene, i, seed, target, records, count, capacity);
}
