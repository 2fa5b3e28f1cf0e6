// Dielectric interfaces (glass, water): exact Fresnel reflectance, Snell refraction, the smooth
// interface as a pair of delta lobes and the rough one as Walter et al.'s microfacet BSDF (GGX or Beckmann)
// ("Microfacet Models for Refraction through Rough Surfaces", EGSR 2007).
//
// Conventions: directions are unit vectors in world space pointing away from the surface; n is
// the normal on wo's side (cos(wo, n) >= 0); eta = n(transmitted side) / n(wo's side), so the
// caller inverts the relative index when the ray leaves the object.
//
// Transport: we trace radiance from the camera, and radiance is not invariant across an
// interface: L_t = (1 - F) (n_t / n_i)^2 L_i. A camera path that refracts into a medium of
// relative index eta therefore carries 1/eta^2 (pbrt-v4, TransportMode::Radiance). Over a path
// that starts and ends in the same medium the factors cancel (a furnace is unaffected); they
// matter when the camera or an emitter sits inside a medium. The path tracer keeps the product
// of eta^2 aside so that Russian roulette does not kill paths for being inside glass.
#ifndef CLRENDER_DIELECTRIC_H
#define CLRENDER_DIELECTRIC_H
#include "math.h"
#include "materials/bsdf_sample.h"
#include "materials/microfacet.h"
#include "materials/dielectric_smooth.h"
#if DIELECTRIC

// ----- rough interface: microfacets (materials/microfacet.h) -------------------------------------
// f * |cos_i| (Walter et al. 2007, eqs. 20-21); reflection is tinted by reflect_tint (Mitsuba's
// specular_reflectance), transmission by tint (specular_transmittance). Transmission uses the
// generalised half vector h ~ -(wo + eta wi) (eq. 16); the microfacet must face wo and be
// crossed by wi, otherwise that configuration has no microfacet explaining it. Since
// wo.h + eta wi.h = |wo + eta wi|, the squared denominator of eq. 21 is |wo + eta wi|^2 / eta^2,
// which never vanishes, and its eta^2 cancels the 1/eta^2 of radiance transport.
float3 eval_dielectric(float3 reflect_tint, float3 tint, float eta, Microfacet mf, float3 n, float3 wo,
                       float3 wi) {
    float cos_o = dot(n, wo), cos_i = dot(n, wi);
    if (cos_o <= 0.0f || cos_i == 0.0f) return (float3)(0.0f);
    if (cos_i > 0.0f) {
        float3 h = normalize(wo + wi);  // |wo + wi| > 0: both lie above the surface
        float f = fresnel_dielectric(dot(wo, h), eta);
        return reflect_tint * (f * microfacet_d(mf, n, h) * microfacet_g(mf, cos_o, cos_i) / (4.0f * cos_o));
    }
    float3 ht = wo + eta * wi;
    float len2 = dot(ht, ht);
    if (!(len2 > 0.0f)) return (float3)(0.0f);
    float3 h = ht * rsqrt(len2);
    if (dot(n, h) < 0.0f) h = -h;
    float cos_oh = dot(wo, h), cos_ih = dot(wi, h);
    if (cos_oh <= 0.0f || cos_ih >= 0.0f) return (float3)(0.0f);
    float f = fresnel_dielectric(cos_oh, eta);
    float value = (1.0f - f) * microfacet_d(mf, n, h) * microfacet_g(mf, cos_o, cos_i) * cos_oh * -cos_ih /
                  (cos_o * len2);
    return tint * value;
}

// Density of sample_dielectric: the visible-normal density, times the probability of the lobe
// chosen at that normal (F or 1 - F), times the Jacobian from h to wi (1 / (4 wo.h) for
// reflection; eta^2 |wi.h| / |wo + eta wi|^2 for refraction, Walter et al. eq. 17).
float sample_dielectric_pdf(float eta, Microfacet mf, float3 n, float3 wo, float3 wi) {
    float cos_o = dot(n, wo), cos_i = dot(n, wi);
    if (cos_o <= 0.0f || cos_i == 0.0f) return 0.0f;
    if (cos_i > 0.0f) {
        float3 h = normalize(wo + wi);
        float cos_oh = dot(wo, h);
        float f = fresnel_dielectric(cos_oh, eta);
        return cos_oh > 0.0f ? f * sample_microfacet_visible_pdf(mf, n, wo, h) / (4.0f * cos_oh) : 0.0f;
    }
    float3 ht = wo + eta * wi;
    float len2 = dot(ht, ht);
    if (!(len2 > 0.0f)) return 0.0f;
    float3 h = ht * rsqrt(len2);
    if (dot(n, h) < 0.0f) h = -h;
    float cos_oh = dot(wo, h), cos_ih = dot(wi, h);
    if (cos_oh <= 0.0f || cos_ih >= 0.0f) return 0.0f;
    float f = fresnel_dielectric(cos_oh, eta);
    return (1.0f - f) * sample_microfacet_visible_pdf(mf, n, wo, h) * eta * eta * -cos_ih / len2;
}

// A visible microfacet normal, then reflection or refraction about it chosen by its Fresnel
// term. A direction that ends on the wrong side of the macro surface (reflected below it or
// refracted above it) is rejected rather than kept: otherwise two mechanisms could produce the
// same wi and sample_dielectric_pdf, which counts one, would understate the density.
// Returns the zero vector for no sample.
float3 sample_dielectric(float eta, Microfacet mf, float3 n, float3 wo, float rnl, float2 rn) {
    float3 h = sample_microfacet_visible(mf, n, wo, rn);
    float cos_oh = dot(wo, h);
    if (cos_oh <= 0.0f) return (float3)(0.0f);
    float3 wi;
    if (rnl < fresnel_dielectric(cos_oh, eta)) {
        wi = reflect(wo, h);
        return dot(n, wi) > 0.0f ? wi : (float3)(0.0f);
    }
    if (!refract(wo, h, eta, &wi) || dot(n, wi) >= 0.0f) return (float3)(0.0f);
    return wi;
}

#endif
#endif
