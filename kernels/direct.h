// Mitsuba's direct integrator (render.integrator "direct"; RenderParams.sampling.y, .z): the
// camera ray's first surface is lit by n_l light samples and n_b BSDF samples, each sample
// weighted by the power heuristic over the two techniques' pdfs times their sample counts
// (Veach's multi-sample MIS) and divided by its own count; nothing else, no indirect light and
// no media. Emitters and the environment are seen directly (unless hidden from the camera) and
// through the BSDF samples, so also in smooth mirrors and glass, one bounce deep.
#ifndef CLRENDER_DIRECT_H
#define CLRENDER_DIRECT_H
#include "rng.h"
#include "scene.h"
#include "materials/material.h"
#include "materials/textured_params.h"
#include "materials/bsdf.h"
#include "aovs.h"
#include "path.h"
#include "direct_samples.h"

// The emission one BSDF sample from sp finds, MIS-weighted against n_light light samples.
float3 direct_bsdf_sample(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                          int n_light, int n_bsdf, Rng* rng) {
    BsdfSample bs = sample_bsdf(scene, m, sp, wo, rng);
    bs.weight *= shading_map_factor(m, sp, bs.wi);
    if (!(bs.pdf_w > 0.0f) || is_black(bs.weight)) return (float3)(0.0f);
    // The power heuristic is scale-invariant: the pdf times n_b / n_l weighs the counts; without
    // light samples the BSDF sample has the whole weight, as a delta one.
    bool alone = bs.delta || n_light == 0;
    float pdf_w = alone ? 0.0f : bs.pdf_w * ((float)n_bsdf / (float)n_light);
    float3 origin = spawn_ray_origin(sp, bs.wi);
    Hit hit;
    if (!intersect_scene(scene, origin, bs.wi, INFINITY, &hit))
        return bs.weight * escaped_radiance(scene, bs.wi, pdf_w, alone);
    SurfacePoint light = surface_point(scene, &hit, bs.wi);
    Material lm = surface_material(scene, &light);
    return bs.weight * emitted_radiance(scene, &lm, &light, sp->p, bs.wi, pdf_w, alone);
}

// The radiance of one camera sample, as Mitsuba's direct integrator estimates it. A camera ray
// that passes a mask (the probability 1 - opacity of Mitsuba's null component) sees only what
// emits behind it, as Mitsuba's direct integrator sees through a mask's null lobe.
float3 trace_direct(const Scene* scene, Ray ray, Rng* rng, AovSample* aov) {
    int n_light = scene->params->sampling.y, n_bsdf = scene->params->sampling.z;
    bool hide_environment = (scene->params->environment.w & HIDE_ENVIRONMENT) != 0;
    float3 radiance = (float3)(0.0f);
    bool through_mask = false;
    Hit hit;
    SurfacePoint sp;
    Material m;
    for (int crossing = 0;; ++crossing) {
        if (!intersect_scene(scene, ray.origin, ray.direction, INFINITY, &hit)) {
            bool visible = !hide_environment || through_mask;
            aov_record_escape(aov, scene, ray.direction, (float3)(1.0f), 1.0f, visible);
            return visible ? radiance + escaped_radiance(scene, ray.direction, 0.0f, true) : radiance;
        }
        if (crossing == MAX_NULL_CROSSINGS) return radiance;
        sp = surface_point(scene, &hit, ray.direction);
        if (hidden_from_camera(scene, &sp) && !through_mask) {
            ray.origin = spawn_ray_origin(&sp, ray.direction);
            continue;
        }
        m = surface_material(scene, &sp);
        radiance += emitted_radiance(scene, &m, &sp, ray.origin, ray.direction, 0.0f, true);
        if (through_mask) return radiance;
#if TEXTURES
        if (passes_through_mask(&m, rng)) {
            through_mask = true;
            ray.origin = spawn_ray_origin(&sp, ray.direction);
            continue;
        }
        bend_shading_normal(scene, &m, &sp, -ray.direction);
#endif
        break;
    }
    if (!material_is_delta(&m)) aov_record_surface(aov, &m, &sp, (float3)(1.0f), 1.0f);
    float3 wo = -ray.direction;
    if (!material_is_delta(&m) && n_light > 0) {
        float3 lit = (float3)(0.0f);
        for (int i = 0; i < n_light; ++i)
            lit += direct_light(scene, &m, &sp, wo, -1, (float)n_bsdf / (float)n_light, rng_float2(rng), rng);
        radiance += lit / (float)n_light;
    }
    if (n_bsdf > 0 && emission_can_be_hit(scene)) {
        float3 found = (float3)(0.0f);
        for (int i = 0; i < n_bsdf; ++i) found += direct_bsdf_sample(scene, &m, &sp, wo, n_light, n_bsdf, rng);
        radiance += found / (float)n_bsdf;
    }
    return radiance;
}

#endif
