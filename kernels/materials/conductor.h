// Conductors (metals): reflectance = tint x the Fresnel reflectance of a complex index of
// refraction eta + i k per RGB channel (Mitsuba 3's conductor and roughconductor), smooth (a
// delta lobe) or rough (a microfacet lobe: materials/microfacet.h, VNDF sampling). eta = k = 0
// is a perfect mirror, F = 1 (a conductor given only its tint).
// Conventions as in dielectric.h: unit world-space directions away from the surface, n on wo's
// side. Uses reflect() from dielectric_smooth.h; the smooth lobe and the Fresnel term are in
// conductor_smooth.h.
#ifndef CLRENDER_CONDUCTOR_H
#define CLRENDER_CONDUCTOR_H
#include "math.h"
#include "materials/bsdf_sample.h"
#include "materials/microfacet.h"
#include "materials/dielectric_smooth.h"
#include "materials/conductor_smooth.h"
#if DIELECTRIC

float3 eval_conductor(float3 tint, float3 eta, float3 k, Microfacet mf, float3 n, float3 wo, float3 wi) {
    float cos_o = dot(n, wo), cos_i = dot(n, wi);
    if (cos_o <= 0.0f || cos_i <= 0.0f) return (float3)(0.0f);
    float3 h = normalize(wo + wi);
    float3 f = fresnel_conductor(clamp(dot(wo, h), 0.0f, 1.0f), eta, k);
    return tint * f * (microfacet_d(mf, n, h) * microfacet_g(mf, cos_o, cos_i) / (4.0f * cos_o));
}

float sample_conductor_pdf(Microfacet mf, float3 n, float3 wo, float3 wi) {
    float cos_o = dot(n, wo), cos_i = dot(n, wi);
    if (cos_o <= 0.0f || cos_i <= 0.0f) return 0.0f;
    float3 h = normalize(wo + wi);
    float cos_oh = dot(wo, h);
    return cos_oh > 0.0f ? sample_microfacet_visible_pdf(mf, n, wo, h) / (4.0f * cos_oh) : 0.0f;
}

// Zero vector for no sample (mirrored below the macro surface; see sample_dielectric).
float3 sample_conductor(Microfacet mf, float3 n, float3 wo, float2 rn) {
    float3 wi = reflect(wo, sample_microfacet_visible(mf, n, wo, rn));
    return dot(n, wi) > 0.0f ? wi : (float3)(0.0f);
}

#endif
#endif
