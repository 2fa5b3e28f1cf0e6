// Emitters: area triangles, the environment (constant or lat-long image), point and directional
// lights. One emitter is picked per shading point with probability proportional to its power.
#ifndef CLRENDER_LIGHTS_H
#define CLRENDER_LIGHTS_H
#include "types.h"
#include "math.h"
#include "rng.h"
#include "sampling.h"
#include "scene.h"

typedef struct {
    float3 wi;        // unit direction towards the light
    float dist;       // distance to the sampled point (INFINITY for the environment/directional)
    float3 radiance;  // arriving radiance (irradiance-like for delta lights), before the pdf
    float pdf_w;      // solid-angle pdf including the selection probability; 1 * pmf for delta
    bool delta;
} LightSample;

// ----- environment ---------------------------------------------------------------------------
#if ENVIRONMENT == ENVIRONMENT_IMAGE
// Lat-long, +y up; u = 0.5 looks down -z.
float2 direction_to_latlong(float3 d) {
    float u = atan2(d.x, -d.z) * (0.5f * INV_PI_F) + 0.5f;
    float v = acos(clamp(d.y, -1.0f, 1.0f)) * INV_PI_F;
    return (float2)(u, v);
}

int environment_texel(const Scene* scene, float2 uv) {
    int w = scene->params->environment.y, h = scene->params->environment.z;
    int i = min((int)(uv.x * (float)w), w - 1), j = min((int)(uv.y * (float)h), h - 1);
    return j * w + max(i, 0);
}

float environment_pdf_w(const Scene* scene, float3 dir) {
    int w = scene->params->environment.y, h = scene->params->environment.z;
    float2 uv = direction_to_latlong(dir);
    int texel = environment_texel(scene, uv);
    int j = texel / w, i = texel - j * w;
    __global const float* marginal = scene->env_cdf;
    __global const float* conditional = scene->env_cdf + (h + 1) + j * (w + 1);
    float pdf_uv = (float)(w * h) * (marginal[j + 1] - marginal[j]) * (conditional[i + 1] - conditional[i]);
    float sin_theta = sin(uv.y * PI_F);
    return sin_theta > 0.0f ? pdf_uv / (2.0f * PI_F * PI_F * sin_theta) : 0.0f;
}

float3 environment_radiance(const Scene* scene, float3 dir) {
    return scene->env_texels[environment_texel(scene, direction_to_latlong(dir))].xyz;
}

// Piecewise-constant inversion: a row from the marginal CDF, then a column in that row.
float3 sample_environment_direction(const Scene* scene, float2 u) {
    int w = scene->params->environment.y, h = scene->params->environment.z;
    __global const float* marginal = scene->env_cdf;
    int j = sample_discrete_cdf(marginal, h, u.x);
    float v = ((float)j + (u.x - marginal[j]) / fmax(marginal[j + 1] - marginal[j], 1e-30f)) / (float)h;
    __global const float* conditional = scene->env_cdf + (h + 1) + j * (w + 1);
    int i = sample_discrete_cdf(conditional, w, u.y);
    float uu = ((float)i + (u.y - conditional[i]) / fmax(conditional[i + 1] - conditional[i], 1e-30f)) / (float)w;
    float theta = clamp(v, 0.0f, 1.0f) * PI_F;
    float sin_phi, cos_phi;
    sincos_2pi(uu - 0.5f, &sin_phi, &cos_phi);
    float sin_theta = sin(theta);
    return (float3)(sin_theta * sin_phi, cos(theta), -sin_theta * cos_phi);
}
#elif ENVIRONMENT == ENVIRONMENT_CONSTANT
float environment_pdf_w(const Scene* scene, float3 dir) { return UNIFORM_SPHERE_PDF_W; }

float3 environment_radiance(const Scene* scene, float3 dir) {
    return scene->emitters[scene->params->environment.x].radiance.xyz;
}

float3 sample_environment_direction(const Scene* scene, float2 u) { return sample_uniform_sphere(u); }
#endif

// ----- area lights ---------------------------------------------------------------------------
// Solid-angle pdf of reaching a point on an emitting triangle, given the distance and cosine.
float triangle_emitter_pdf_w(__global const Emitter* e, float dist, float cos_light) {
    return cos_light > 0.0f ? dist * dist / (cos_light * e->p0.w) : 0.0f;
}

// ----- point and directional lights ----------------------------------------------------------
// The light arriving at p from a point or directional emitter, with pdf_w = pmf (the
// probability of having chosen it). Returns false for other kinds or a point light at p.
bool delta_light_sample(__global const Emitter* e, float3 p, float pmf, LightSample* ls) {
    int kind = e->kind.x;
    if (kind == EMITTER_POINT) {
        float3 d = e->p0.xyz - p;
        float dist2 = dot(d, d);
        if (!(dist2 > 0.0f)) return false;
        ls->dist = sqrt(dist2);
        ls->wi = d / ls->dist;
        ls->radiance = e->radiance.xyz / dist2;
    } else if (kind == EMITTER_DIRECTIONAL) {
        ls->wi = e->p0.xyz;
        ls->dist = INFINITY;
        ls->radiance = e->radiance.xyz;
    } else {
        return false;
    }
    ls->pdf_w = pmf;
    ls->delta = true;
    return true;
}

// ----- one sample --------------------------------------------------------------------------
LightSample sample_light(const Scene* scene, float3 p, Rng* rng) {
    LightSample ls;
    ls.pdf_w = 0.0f;
    ls.delta = false;
    ls.dist = INFINITY;
    ls.radiance = (float3)(0.0f);
    ls.wi = (float3)(0.0f, 0.0f, 1.0f);
    int count = scene->params->config.w;
    float u_select = rng_float(rng);
    float2 u = rng_float2(rng);
    if (count == 0) return ls;
    int index = sample_discrete_cdf(scene->emitter_cdf, count, u_select);
    float pmf = emitter_selection_pmf(scene, index);
    __global const Emitter* e = scene->emitters + index;
    int kind = e->kind.x;
    if (kind == EMITTER_TRIANGLE) {
        float2 b = sample_triangle(u);
        float3 n_light = normalize(cross(e->e1.xyz, e->e2.xyz));
        float3 q = e->p0.xyz + b.x * e->e1.xyz + b.y * e->e2.xyz;
        // q is off the light's plane by up to its rounding error, which far from the origin
        // exceeds the shadow ray's relative margin: move it off the plane towards p by that
        // bound (as spawned rays are, scene.h), so the shadow ray stops before the light.
        float3 magnitude = fabs(e->p0.xyz) + fabs(e->e1.xyz) + fabs(e->e2.xyz);
        q = offset_ray_origin(q, dot(p - q, n_light) > 0.0f ? n_light : -n_light,
                              SURFACE_ERROR_EPS * dot(fabs(n_light), magnitude));
        float3 d = q - p;
        float dist = length(d);
        if (!(dist > 0.0f)) return ls;
        ls.wi = d / dist;
        ls.dist = dist;
        float cos_light = -dot(ls.wi, n_light);
        ls.pdf_w = pmf * triangle_emitter_pdf_w(e, dist, cos_light);
        ls.radiance = ls.pdf_w > 0.0f ? e->radiance.xyz : (float3)(0.0f);
    }
#if ENVIRONMENT != ENVIRONMENT_NONE
    else if (kind == EMITTER_ENVIRONMENT) {
        ls.wi = sample_environment_direction(scene, u);
        ls.pdf_w = pmf * environment_pdf_w(scene, ls.wi);
        ls.radiance = environment_radiance(scene, ls.wi);
    }
#endif
    else if (kind == EMITTER_POINT || kind == EMITTER_DIRECTIONAL) {
        delta_light_sample(e, p, pmf, &ls);
    }
    return ls;
}

#endif
