// Emitters: area lights (emissive triangles and spheres), the environment (constant or lat-long
// image), point, spot and directional lights. One emitter is picked per shading point, half
// by power, half uniformly as Mitsuba (clrender/light_selection.py builds the CDF).
#ifndef CLRENDER_LIGHTS_H
#define CLRENDER_LIGHTS_H
#include "types.h"
#include "math.h"
#include "sampling.h"
#include "scene.h"

#include "sphere.h"
#include "triangle_lights.h"
#include "area_lights.h"
#include "delta_lights.h"
#include "textures/texture.h"
#include "environment.h"

typedef struct {
    float3 wi;        // unit direction towards the light
    float dist;       // distance to the sampled point (INFINITY for the environment/directional)
    float3 radiance;  // arriving radiance (irradiance-like for delta lights), before the pdf;
                      // the environment image's: 1 until light_sample_radiance looks it up
    float2 env_uv;    // the environment image's (u, v) drawn
    float pdf_w;      // solid-angle pdf including the selection probability; 1 * pmf for delta
    bool delta;
    int emitter;      // the emitter picked
} LightSample;

// ----- area lights: their radiance (sampling and densities: area_lights.h) -----------------
// The radiance of area emitter e at its point q, sampled with u: Emitter.radiance, or where its
// lane w names a texture (as materials/textured_params.h), the texture's value at q's uv (the
// primitive slot in kind.y).
float3 area_emitter_radiance(const Scene* scene, __global const Emitter* e, float2 u, float3 q) {
#if TEXTURES
    if (e->radiance.w >= 0.0f) {
        int slot = e->kind.y;
        float2 uv;
        if (e->kind.x == EMITTER_SPHERE) {
            float3 dpdu, dpdv;
            uv = sphere_uv(scene->spheres + slot, normalize(q - e->p0.xyz), &dpdu, &dpdv);
        } else {
            float2 b = sample_triangle(u);   // as sample_triangle_emitter placed q
            uv = triangle_uv(scene, slot, b.x, b.y);
        }
        return eval_texture(scene, (int)e->radiance.w >> 1, uv);
    }
#endif
    return e->radiance.xyz;
}

// ----- point, spot and directional lights ----------------------------------------------------
// The light arriving at p from a point, spot or directional emitter (delta_lights.h), with pdf_w =
// pmf (the probability of having chosen it). Returns false for other kinds or a point or spot
// light at p.
bool delta_light_sample(__global const Emitter* e, float3 p, float pmf, LightSample* ls) {
    if (!delta_light_arriving(e, 0, p, &ls->wi, &ls->dist, &ls->radiance)) return false;
    ls->pdf_w = pmf;
    ls->delta = true;
    return true;
}

// ----- one sample --------------------------------------------------------------------------
// One 2D draw u picks the emitter (u.x) and, rescaled, places the sample on it: the points of a
// stratified draw stay stratified over the whole light rather than over the share of them that
// an independent pick sends to each emitter, and the draw saves a dimension.
INLINE LightSample sample_light(const Scene* scene, float3 p, float2 u) {
    LightSample ls;
    ls.emitter = -1;
    ls.pdf_w = 0.0f;
    ls.delta = false;
    ls.dist = INFINITY;
    ls.radiance = (float3)(0.0f);
    ls.wi = (float3)(0.0f, 0.0f, 1.0f);
    int count = scene->params->config.w;
    if (count == 0) return ls;
    float u_on_emitter;
    int index = sample_discrete_cdf_reuse(scene->emitter_cdf, count, u.x, &u_on_emitter);
    ls.emitter = index;
    u.x = u_on_emitter;
    float pmf = emitter_selection_pmf(scene, index);
    __global const Emitter* e = scene->emitters + index;
    int kind = e->kind.x;
    if (kind == EMITTER_TRIANGLE) {
        float dist, pdf_w;
        float3 wi = sample_triangle_emitter(scene, index, p, u, &dist, &pdf_w);
        if (!(dist > 0.0f)) return ls;
        ls.wi = wi;
        ls.dist = dist;
        ls.pdf_w = pmf * pdf_w;
        ls.radiance = ls.pdf_w > 0.0f ? area_emitter_radiance(scene, e, u, p + dist * wi) : (float3)(0.0f);
    } else if (kind == EMITTER_SPHERE) {
        float pdf_w;
        float3 q = sample_sphere_emitter(scene->emitters, index, p, u, &pdf_w);
        float3 d = q - p;
        float dist = length(d);
        if (!(pdf_w > 0.0f && dist > 0.0f)) return ls;
        ls.wi = d / dist;
        ls.dist = dist;
        ls.pdf_w = pmf * pdf_w;
        ls.radiance = area_emitter_radiance(scene, e, u, q);
    }
#if ENVIRONMENT != ENVIRONMENT_NONE
    else if (kind == EMITTER_ENVIRONMENT) {
        float pdf_w;
        ls.wi = sample_environment_direction(scene, u, &pdf_w, &ls.env_uv);
        ls.pdf_w = pmf * pdf_w;
        ls.radiance = (float3)(1.0f);
    }
#endif
    else if (kind == EMITTER_POINT || kind == EMITTER_SPOT || kind == EMITTER_DIRECTIONAL) {
        delta_light_sample(e, p, pmf, &ls);
    }
    return ls;
}

// The radiance a light sample brings. The environment image's is looked up only here, which
// callers reach once the shadow ray has passed: blocked samples skip its texels, whose cache
// misses were a fifth of the living room's render (docs/performance.md).
float3 light_sample_radiance(const Scene* scene, const LightSample* ls) {
#if ENVIRONMENT != ENVIRONMENT_NONE
    if (ls->emitter >= 0 && ls->emitter == scene->params->environment.x) return environment_radiance_at(scene, ls->env_uv);
#endif
    return ls->radiance;
}

#endif
