// Conductors (metals): reflectance = tint x the Fresnel reflectance of a complex index of
// refraction eta + i k per RGB channel (Mitsuba 3's conductor and roughconductor), smooth (a
// delta lobe) or rough (a microfacet lobe: materials/microfacet.h, VNDF sampling). eta = k = 0
// is a perfect mirror, F = 1 (a conductor given only its tint).
// Conventions as in dielectric.h: unit world-space directions away from the surface, n on wo's
// side. Uses reflect() from dielectric_smooth.h.
#ifndef CLRENDER_CONDUCTOR_H
#define CLRENDER_CONDUCTOR_H
#include "math.h"
#include "materials/bsdf_sample.h"
#include "materials/microfacet.h"
#include "materials/dielectric_smooth.h"
#if DIELECTRIC

// Unpolarised Fresnel reflectance of a conductor, per channel, at cos_i in [0, 1] (Mitsuba 3's
// fresnel_conductor, after K. D. Moeller, "Optics", 1988; exact, with a^2 + b^2 = |eta^2 - sin^2|).
// eta = k = 0 reflects everything; said outright, since the formula divides 0 by 0 at normal
// incidence there.
float3 fresnel_conductor(float cos_i, float3 eta, float3 k) {
    float c2 = cos_i * cos_i, s2 = 1.0f - c2, s4 = s2 * s2;
    float3 t = eta * eta - k * k - s2;
    float3 a2_b2 = sqrt(fmax(t * t + 4.0f * k * k * eta * eta, 0.0f));
    float3 a = sqrt(fmax(0.5f * (a2_b2 + t), 0.0f));
    float3 t1 = a2_b2 + c2, t2 = 2.0f * cos_i * a;
    float3 r_s = (t1 - t2) / (t1 + t2);
    float3 t3 = a2_b2 * c2 + s4, t4 = t2 * s2;
    float3 r_p = r_s * (t3 - t4) / (t3 + t4);
    return select(0.5f * (r_s + r_p), (float3)(1.0f), (eta == 0.0f) & (k == 0.0f));
}

// ng: the geometric normal on wo's side. An interpolated normal can mirror wo into the surface
// near silhouettes; the facet's own mirror direction is used then, which keeps the energy.
BsdfSample sample_conductor_delta(float3 tint, float3 eta, float3 k, float3 n, float3 ng, float3 wo) {
    BsdfSample bs = bsdf_sample_none();
    bs.delta = true;
    bs.wi = reflect(wo, n);
    float3 mirror = n;
    if (dot(bs.wi, ng) <= 0.0f) {
        bs.wi = reflect(wo, ng);
        mirror = ng;
    }
    bs.weight = tint * fresnel_conductor(clamp(dot(wo, mirror), 0.0f, 1.0f), eta, k);
    bs.pdf_w = 1.0f;
    return bs;
}

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
