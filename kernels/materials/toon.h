// Cel ("toon") shading inside the path tracer: the classic cel formula
//
//     light_intensity = smoothstep(0, 0.01, N.L)
//     specular        = highlight where R.V is near 1, R = the reflection of L about N
//     rim             = glow where N.V is small
//     C'              = C * 0.1 if the shadow ray to the light is blocked, else C
//     result          = C' * (specular + light_intensity + ambient + rim)
//
// generalised to any number of lights, media and extended by options whose defaults leave it
// unchanged (docs/materials-toon.md has the derivation and every parameter):
//
//     result = C * [ sum_j s_j T_j (band(N.L_j) + specular_j)  +  visibility * (ambient + rim) ]
//     visibility = b + (1 - b) * sum_j p_j T_j      (1 without lights),   b = shadow_factor * shadow_color
//
// s_j: the light's strength, its irradiance / pi (a white Lambertian surface facing a unit-strength
// light shows 1, so toon and physical objects share one exposure); T_j: its transmittance along
// the shadow ray, 0 where an opaque surface blocks it or it is below the surface, exp(-tau)
// through media, 1 in vacuum; p_j: its share of the scene's light power (Emitter e2.w; next-event
// estimation picks lights by a mixture of power and count instead). With one light and T = 0 or 1 this is the formula: a
// blocked point shows C * 0.1 * (ambient + rim), its light term being blocked too.
//
// A toon surface is shaded, not scattered: a path vertex that hits one adds
// throughput * eval_toon_radiance(...) and the path ends (path.h). So a toon object looks the
// same seen directly, in a mirror or through glass (only the throughput differs), and physical
// surfaces next to it receive its toon radiance as indirect light; it still casts shadows.
//
// Which lights: point and directional lights are few and noiseless, so every one is evaluated
// (deterministic, hard shadows). Area lights (emissive triangles and spheres) get one sample
// per vertex, as next-event estimation draws it, and the environment one sample of its own,
// weighted by 1 / pdf: unbiased estimates of the integrals over the light, converging with the
// samples per pixel.
#ifndef CLRENDER_TOON_H
#define CLRENDER_TOON_H
#include "math.h"
#include "rng.h"
#include "sampling.h"
#include "scene.h"
#include "lights.h"
#include "materials/material.h"
#include "media/transport.h"

#if TOON

// smoothstep(0, width, x). Width 0 is the crisp step x > 0 (no division by zero), so the
// default band edge smoothstep(0, 0.01, N.L) and a zero softness both behave.
float toon_step(float x, float width) {
    if (!(width > 0.0f)) return x > 0.0f ? 1.0f : 0.0f;
    float t = clamp(x / width, 0.0f, 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

// light_intensity with `bands` lit tones: edges at N.L = k / bands (k = 0 .. bands - 1), each a
// smoothstep of width `softness`; one band is the formula's smoothstep(0, softness, N.L). With
// crisp edges the values are exactly 0, 1/n, ..., 1. The count is divided once at the end so
// that level k is the correctly rounded k / n, the same float wherever it occurs.
float toon_band(float n_dot_l, int bands, float softness) {
    float levels = 0.0f;
    for (int k = 0; k < bands; ++k) levels += toon_step(n_dot_l - (float)k / (float)bands, softness);
    return levels / (float)bands;
}

// Highlight strength: on where R.V exceeds 1 - size, reaching full strength `softness` later.
float toon_highlight(const Material* m, float r_dot_v) {
    float size = material_toon_highlight_size(m);
    return size > 0.0f ? toon_step(r_dot_v - (1.0f - size), material_toon_highlight_softness(m)) : 0.0f;
}

// Rim: on only where the view grazes the surface, N.V < threshold, reaching full strength
// `width` below it. Threshold 0 switches it off.
float3 toon_rim(const Material* m, float n_dot_v) {
    return material_toon_rim_color(m) * toon_step(material_toon_rim_threshold(m) - n_dot_v, material_toon_rim_width(m));
}

// light_intensity + specular for one light direction wi (unit, towards the light), before the
// light's strength and transmittance. The highlight is gated by the first band edge, so it
// fades with the lit side at the terminator (R.V can only come near 1 behind it at grazing
// views, where it would otherwise light up a dark silhouette).
float3 toon_light_terms(const Material* m, float3 n, float3 wo, float3 wi) {
    float n_dot_l = dot(n, wi);
    float softness = material_toon_band_softness(m);
    float intensity = toon_band(n_dot_l, (int)material_toon_bands(m), softness);
    float3 r = 2.0f * n_dot_l * n - wi;  // the reflection of L about N
    float highlight = toon_highlight(m, dot(r, wo)) * toon_step(n_dot_l, softness);
    return intensity + material_toon_highlight_color(m) * highlight;
}

// T_j: the light's transmittance from the toon point, through interface boundaries and media
// like any shadow ray. A light below the geometric surface is blocked by the surface itself
// (the classic shader's self-shadowing): no ray is needed to know it.
float3 toon_light_transmittance(const Scene* scene, const SurfacePoint* sp, float3 wi, float dist,
                                int medium, Rng* rng) {
    if (dot(wi, sp->ng) <= 0.0f) return (float3)(0.0f);
    float pdf_ratio;  // MIS between transmittance estimators: not needed, toon takes one technique
    return shadow_ray(scene, spawn_ray_origin(sp, wi), wi, dist, medium, rng, &pdf_ratio);
}

// The sums over lights: lit = sum_j s_j pi T_j (band + specular) and reached = sum_j p_j T_j.
typedef struct {
    float3 lit;
    float3 reached;
} ToonLighting;

// One light (or one sample of it) arriving from wi: `irradiance` = s_j pi (or its estimate
// radiance / pdf), `share` = p_j (or the estimator's weight for it).
void toon_add_light(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                    float3 wi, float dist, float3 irradiance, float share, int medium, Rng* rng,
                    ToonLighting* lighting) {
    float3 tr = toon_light_transmittance(scene, sp, wi, dist, medium, rng);
    lighting->reached += share * tr;
    if (!is_black(tr)) lighting->lit += irradiance * tr * toon_light_terms(m, sp->ns, wo, wi);
}

#if ENVIRONMENT != ENVIRONMENT_NONE
// The environment, with its own sample at every toon vertex:
//  - constant sky: a uniform direction and its opposite (antithetic pair, each of pdf
//    1 / (4 pi), each half the estimate). The light terms vanish below the surface, so one of
//    the two always lands where they live; the lower one needs no shadow ray.
//  - image: one direction importance-sampled from the image (by luminance, so its
//    transmittance estimates the luminance-weighted mean over the sky).
void toon_environment(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                      int medium, Rng* rng, ToonLighting* lighting) {
    int env = scene->params->environment.x;
    float2 u = rng_float2(rng);
    if (env < 0) return;
    float share = emitter_power_share(scene, env);
#if ENVIRONMENT == ENVIRONMENT_CONSTANT
    float3 wi = sample_uniform_sphere(u);
    float3 irradiance = environment_radiance(scene, wi) * (2.0f * PI_F);  // (1/2) / pdf
    toon_add_light(scene, m, sp, wo, wi, INFINITY, irradiance, 0.5f * share, medium, rng, lighting);
    toon_add_light(scene, m, sp, wo, -wi, INFINITY, irradiance, 0.5f * share, medium, rng, lighting);
#else
    float pdf_w;
    float2 uv;
    float3 wi = sample_environment_direction(scene, u, &pdf_w, &uv);
    if (pdf_w > 0.0f)
        toon_add_light(scene, m, sp, wo, wi, INFINITY, environment_radiance_at(scene, uv) / pdf_w, share, medium,
                       rng, lighting);
#endif
}
#endif

// Radiance leaving a toon surface towards wo (the formula at the top of this file); `medium`:
// the medium on the side the path arrived from, where the shadow rays start.
float3 eval_toon_radiance(const Scene* scene, const Material* m, const SurfacePoint* sp,
                          float3 wo, int medium, Rng* rng) {
    ToonLighting lighting;
    lighting.lit = (float3)(0.0f);
    lighting.reached = (float3)(0.0f);
    // Point and directional lights follow the area lights in the emitter array.
    int count = scene->params->config.w;
    for (int i = scene->params->lights.x; i < count; ++i) {
        LightSample ls;
        if (delta_light_sample(scene->emitters + i, sp->p, 1.0f, &ls))
            toon_add_light(scene, m, sp, wo, ls.wi, ls.dist, ls.radiance, emitter_power_share(scene, i),
                           medium, rng, &lighting);
    }
#if ENVIRONMENT != ENVIRONMENT_NONE
    toon_environment(scene, m, sp, wo, medium, rng, &lighting);
#endif
    // Area lights (they come first in the emitter array): one sample as next-event estimation
    // draws it. Other emitters drawn here were counted above and are skipped (an area-light
    // sample is the only kind that is not delta and lies at a finite distance). The sample was
    // picked with next-event estimation's probability q_j, so share p_j / q_j makes
    // E[share * T] = sum p_j T_j over the area lights, and radiance / pdf_w (pdf_w includes q_j)
    // estimates their irradiance.
    if (scene->params->lights.x > 0) {
        LightSample ls = sample_light(scene, sp->p, rng_float2(rng));
        if (!ls.delta && ls.dist < INFINITY && ls.pdf_w > 0.0f)
            toon_add_light(scene, m, sp, wo, ls.wi, ls.dist, ls.radiance / ls.pdf_w,
                           emitter_power_share(scene, ls.emitter) / emitter_selection_pmf(scene, ls.emitter),
                           medium, rng, &lighting);
    }
    // Ambient and rim are counted once, dimmed by the shadow factor as far as the light is blocked.
    float3 blocked = material_toon_shadow_color(m) * material_toon_shadow_factor(m);
    float3 visibility = count > 0 ? blocked + (1.0f - blocked) * lighting.reached : (float3)(1.0f);
    float3 once = material_toon_ambient(m) + toon_rim(m, dot(sp->ns, wo));
    return material_color(m) * (lighting.lit * INV_PI_F + visibility * once);
}

#endif  // TOON
#endif
