// Cel ("toon") shading inside the path tracer.
//
// A toon surface is shaded, not scattered: a path vertex that hits one adds
// throughput * eval_toon_radiance(...) and the path ends (path.h). So a toon object looks the
// same seen directly, in a mirror or through glass (only the throughput differs), and physical
// surfaces next to it receive its toon radiance as indirect light; it still casts shadows.
//
// For one light arriving from direction L (unit) with irradiance E, the surface leaves
//
//     E / pi * [ color * (S + (1 - S) * band(N.L) * v)         diffuse tones
//                + highlight_color * highlight(N.H) * [visible]  (only where the light is seen)
//                + rim_color * rim(N.V) * v ]
//
// with S the shadow colour, v = 1 where the light is visible and the shadow factor where a
// shadow ray is blocked or the light is behind the surface, H = normalize(L + V). Several
// lights add up. Dividing by pi makes a fully lit toon point equal a Lambertian one of the same
// colour lit at normal incidence, so toon and physical objects share one exposure; every term is
// proportional to E, so the image stays linear in the light power.
//
// Which lights: point and directional lights are few and noiseless, so every one is evaluated
// (deterministic, hard shadows). Emissive triangles get one sample per vertex, as next-event
// estimation draws it, and the environment one sample of its own, with E = Le / pdf_w: unbiased
// estimates of the integral of the bracket over the light, converging with the samples per
// pixel (shadows and band edges are then soft by the light's extent, as they should be). The
// environment's shadow-tone term does not depend on visibility and is added exactly.
#ifndef CLRENDER_TOON_H
#define CLRENDER_TOON_H
#include "math.h"
#include "rng.h"
#include "sampling.h"
#include "scene.h"
#include "lights.h"
#include "materials/material.h"

#if TOON

// smoothstep(0, width, x). Width 0 is the crisp step x > 0 (no division by zero), so the
// default band edge smoothstep(0, 0.01, N.L) and a zero softness both behave.
float toon_step(float x, float width) {
    if (!(width > 0.0f)) return x > 0.0f ? 1.0f : 0.0f;
    float t = clamp(x / width, 0.0f, 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

// Banded diffuse response in [0, 1]: edges at N.L = k / bands (k = 0 .. bands - 1), each a
// smoothstep of width `softness`. With crisp edges the values are exactly 0, 1/n, ..., 1: the
// shadow tone plus n lit tones. The count is divided once at the end so that level k is the
// correctly rounded k / n, the same float wherever it occurs.
float toon_band(float n_dot_l, int bands, float softness) {
    float levels = 0.0f;
    for (int k = 0; k < bands; ++k) levels += toon_step(n_dot_l - (float)k / (float)bands, softness);
    return levels / (float)bands;
}

// Specular highlight: on where N.H exceeds 1 - size, reaching full strength `softness` later.
float toon_highlight(const Material* m, float n_dot_h) {
    float size = material_toon_highlight_size(m);
    return size > 0.0f ? toon_step(n_dot_h - (1.0f - size), material_toon_highlight_softness(m)) : 0.0f;
}

// Rim light: on only where the view grazes the surface, N.V < threshold, reaching full
// strength `width` below it. Threshold 0 switches it off.
float toon_rim(const Material* m, float n_dot_v) {
    return toon_step(material_toon_rim_threshold(m) - n_dot_v, material_toon_rim_width(m));
}

// The bracket of the formula above splits into the shadow tone color * S, which every light
// adds whatever its visibility, and the lit part, which depends on the light's direction and
// on whether it is seen.
float3 toon_shadow_tone(const Material* m) { return material_color(m) * material_toon_shadow_color(m); }

float3 toon_lit_response(const Material* m, float3 n, float3 wo, float3 wi, bool visible) {
    float v = visible ? 1.0f : material_toon_shadow_factor(m);
    float n_dot_l = dot(n, wi);
    float band = toon_band(n_dot_l, (int)material_toon_bands(m), material_toon_band_softness(m));
    float3 tone = material_color(m) * (1.0f - material_toon_shadow_color(m)) * (band * v);
    float3 h = wi + wo;
    float h_len = length(h);
    if (visible && n_dot_l > 0.0f && h_len > 0.0f)
        tone += material_toon_highlight_color(m) * toon_highlight(m, dot(n, h) / h_len);
    tone += material_toon_rim_color(m) * (toon_rim(m, dot(n, wo)) * v);
    return tone;
}

// Hard shadows: one shadow ray to the light. A light below the geometric surface is shadowed
// by the surface itself; no ray is needed to know it.
bool toon_light_visible(const Scene* scene, const SurfacePoint* sp, float3 wi, float dist) {
    if (dot(wi, sp->ng) <= 0.0f) return false;
    return !occluded(scene, spawn_ray_origin(sp, wi), wi, dist * (1.0f - 1e-4f));
}

float3 toon_lit(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                float3 wi, float dist) {
    return toon_lit_response(m, sp->ns, wo, wi, toon_light_visible(scene, sp, wi, dist));
}

#if ENVIRONMENT != ENVIRONMENT_NONE
// The environment's part, with its own sample at every toon vertex. Its shadow tone ignores
// visibility, so it is exact: the integral of the radiance over the sphere is 4 pi times its
// mean (Emitter.e1). Only the lit part is sampled:
//  - constant sky: a uniform direction and its opposite (antithetic pair, each of pdf
//    1 / (4 pi)). The lit tone vanishes below the surface, so one of the two always lands where
//    it lives and only visibility is left to vary; the lower one usually needs no shadow ray.
//  - image: one direction importance-sampled from the image.
float3 toon_environment(const Scene* scene, const Material* m, const SurfacePoint* sp,
                        float3 wo, float3 shadow_tone, Rng* rng) {
    int env = scene->params->environment.x;
    if (env < 0) return (float3)(0.0f);
    float3 radiance = (4.0f * PI_F) * scene->emitters[env].e1.xyz * shadow_tone;
    float2 u = rng_float2(rng);
#if ENVIRONMENT == ENVIRONMENT_CONSTANT
    float3 wi = sample_uniform_sphere(u);
    float3 lit = toon_lit(scene, m, sp, wo, wi, INFINITY) + toon_lit(scene, m, sp, wo, -wi, INFINITY);
    radiance += environment_radiance(scene, wi) * (2.0f * PI_F) * lit;  // (1/2) / pdf
#else
    float3 wi = sample_environment_direction(scene, u);
    float pdf_w = environment_pdf_w(scene, wi);
    if (pdf_w > 0.0f)
        radiance += environment_radiance(scene, wi) / pdf_w * toon_lit(scene, m, sp, wo, wi, INFINITY);
#endif
    return radiance;
}
#endif

// Radiance leaving a toon surface towards wo (see the top of this file).
float3 eval_toon_radiance(const Scene* scene, const Material* m, const SurfacePoint* sp,
                          float3 wo, Rng* rng) {
    float3 shadow_tone = toon_shadow_tone(m);
    float3 radiance = (float3)(0.0f);
    // Point and directional lights follow the emissive triangles in the emitter array.
    for (int i = scene->params->lights.x; i < scene->params->config.w; ++i) {
        LightSample ls;
        if (!delta_light_sample(scene->emitters + i, sp->p, 1.0f, &ls) || is_black(ls.radiance))
            continue;
        radiance += ls.radiance * (shadow_tone + toon_lit(scene, m, sp, wo, ls.wi, ls.dist));
    }
#if ENVIRONMENT != ENVIRONMENT_NONE
    radiance += toon_environment(scene, m, sp, wo, shadow_tone, rng);
#endif
    // Emissive triangles (they come first in the emitter array): one sample as next-event
    // estimation draws it. Other emitters drawn here were counted above and are skipped (a
    // triangle sample is the only kind that is not delta and lies at a finite distance); the
    // estimate stays unbiased because each sample is divided by the probability of its own
    // selection. The cost: a wasted draw with the probability of the other lights.
    if (scene->params->lights.x > 0) {
        LightSample ls = sample_light(scene, sp->p, rng);
        bool triangle = !ls.delta && ls.dist < INFINITY;
        if (triangle && ls.pdf_w > 0.0f && !is_black(ls.radiance))
            radiance += (ls.radiance / ls.pdf_w) *
                        (shadow_tone + toon_lit(scene, m, sp, wo, ls.wi, ls.dist));
    }
    return radiance * INV_PI_F;
}

#endif  // TOON
#endif
