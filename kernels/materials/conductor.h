// Conductors as tinted mirrors: reflectance = tint at every angle (no complex index of
// refraction), smooth (a delta lobe) or rough (a microfacet lobe: materials/microfacet.h, VNDF sampling).
// Conventions as in dielectric.h: unit world-space directions away from the surface, n on wo's
// side. Uses reflect() from dielectric.h.
#ifndef CLRENDER_CONDUCTOR_H
#define CLRENDER_CONDUCTOR_H
#include "math.h"
#include "materials/bsdf_sample.h"
#include "materials/microfacet.h"
#if DIELECTRIC

// ng: the geometric normal on wo's side. An interpolated normal can mirror wo into the surface
// near silhouettes; the facet's own mirror direction is used then, which keeps the energy.
BsdfSample sample_conductor_delta(float3 tint, float3 n, float3 ng, float3 wo) {
    BsdfSample bs = bsdf_sample_none();
    bs.delta = true;
    bs.wi = reflect(wo, n);
    if (dot(bs.wi, ng) <= 0.0f) bs.wi = reflect(wo, ng);
    bs.weight = tint;
    bs.pdf_w = 1.0f;
    return bs;
}

float3 eval_conductor(float3 tint, Microfacet mf, float3 n, float3 wo, float3 wi) {
    float cos_o = dot(n, wo), cos_i = dot(n, wi);
    if (cos_o <= 0.0f || cos_i <= 0.0f) return (float3)(0.0f);
    float3 h = normalize(wo + wi);
    return tint * (microfacet_d(mf, n, h) * microfacet_g(mf, cos_o, cos_i) / (4.0f * cos_o));
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
