// Dielectric interfaces (glass, water): exact Fresnel reflectance, Snell refraction, the smooth
// interface as a pair of delta lobes and the rough one as Walter et al.'s GGX microfacet BSDF
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
#if DIELECTRIC

// cos of the transmitted angle, from Snell's law written as cos_t^2 = (eta^2 - 1 + cos_i^2) / eta^2
// rather than 1 - sin_t^2: near grazing 1 - (1 - cos_i^2) cancels to a few ulps, and at eta = 1
// this form gives cos_t = cos_i (exactly where sqrt rounds correctly). Negative: total internal
// reflection.
float cos_transmitted(float cos_i, float eta) {
    float g2 = eta * eta - 1.0f + cos_i * cos_i;
    return g2 > 0.0f ? sqrt(g2) / eta : -1.0f;
}

// Unpolarised Fresnel reflectance of a dielectric interface, cos_i in [0, 1] on the incident
// side (Born and Wolf; pbrt-v4 FrDielectric), exact, not Schlick's approximation. Past the
// critical angle it is exactly 1 (total internal reflection). Both denominators are > 0 where
// there is a transmitted ray, since then cos_t > 0.
float fresnel_dielectric(float cos_i, float eta) {
    // No interface reflects nothing and grazing incidence everything; said outright, because the
    // formula gets there only where sqrt(c * c) = c and x / x = 1, i.e. with correctly rounded
    // division and square roots, which GPUs do not give by default (OpenCL allows 2.5 and 3 ulp).
    if (eta == 1.0f) return 0.0f;
    cos_i = clamp(cos_i, 0.0f, 1.0f);
    float cos_t = cos_transmitted(cos_i, eta);
    if (cos_t <= 0.0f || cos_i == 0.0f) return 1.0f;
    float r_parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    float r_perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5f * (r_parallel * r_parallel + r_perpendicular * r_perpendicular);
}

float3 reflect(float3 wo, float3 n) { return normalize(2.0f * dot(wo, n) * n - wo); }

// Snell's law: the transmitted direction for wo on n's side, false under total internal
// reflection.
bool refract(float3 wo, float3 n, float eta, float3* wt) {
    float cos_i = clamp(dot(n, wo), 0.0f, 1.0f);
    float cos_t = cos_transmitted(cos_i, eta);
    if (cos_t <= 0.0f) return false;
    *wt = normalize(-wo / eta + (cos_i / eta - cos_t) * n);
    return true;
}

// ----- smooth interface: two delta lobes, picked with probability F and 1 - F ------------------
// The weight of the chosen lobe is its throughput divided by its probability: 1 for reflection,
// tint / eta^2 for refraction. eta == 1 is an index-matched interface: the ray goes straight on,
// so the object vanishes exactly, with no Fresnel term rounded to a tiny non-zero value.
// n may be an interpolated normal and ng is the facet's, both on wo's side. Near silhouettes n
// can send the reflected ray into the object or the refracted one back out; such a ray would
// cross (or not cross) the interface against its eta^2 scaling, or enter the glass at an angle
// that total internal reflection then traps forever. The facet's normal decides the direction
// then; if refraction about it is impossible, the ray reflects with weight 1 (energy kept).
BsdfSample sample_dielectric_delta(float3 tint, float eta, float3 n, float3 ng, float3 wo,
                                  float rnl) {
    BsdfSample bs = bsdf_sample_none();
    bs.delta = true;
    if (eta == 1.0f) {
        bs.wi = -wo;
        bs.weight = tint;
        bs.pdf_w = 1.0f;
        return bs;
    }
    float f = fresnel_dielectric(dot(n, wo), eta);
    bs.pdf_w = rnl < f ? f : 1.0f - f;
    bool reflected = rnl < f;
    if (!reflected) {
        // f < 1 here, so refraction about n exists; about ng it may not.
        reflected = !refract(wo, n, eta, &bs.wi) ||
                    (dot(bs.wi, ng) >= 0.0f && !refract(wo, ng, eta, &bs.wi));
    }
    if (reflected) {
        bs.wi = reflect(wo, n);
        if (dot(bs.wi, ng) <= 0.0f) bs.wi = reflect(wo, ng);
        bs.weight = (float3)(1.0f);
    } else {
        bs.weight = tint / (eta * eta);
        bs.eta = eta;
    }
    return bs;
}

// ----- rough interface: GGX microfacets ----------------------------------------------------------
// f * |cos_i| (Walter et al. 2007, eqs. 20-21), with height-correlated G2. Transmission uses the
// generalised half vector h ~ -(wo + eta wi) (eq. 16); the microfacet must face wo and be
// crossed by wi, otherwise that configuration has no microfacet explaining it. Since
// wo.h + eta wi.h = |wo + eta wi|, the squared denominator of eq. 21 is |wo + eta wi|^2 / eta^2,
// which never vanishes, and its eta^2 cancels the 1/eta^2 of radiance transport.
float3 eval_dielectric(float3 tint, float eta, float alpha, float3 n, float3 wo, float3 wi) {
    float cos_o = dot(n, wo), cos_i = dot(n, wi);
    if (cos_o <= 0.0f || cos_i == 0.0f) return (float3)(0.0f);
    if (cos_i > 0.0f) {
        float3 h = normalize(wo + wi);  // |wo + wi| > 0: both lie above the surface
        float f = fresnel_dielectric(dot(wo, h), eta);
        return (float3)(f * ggx_d(n, h, alpha) * ggx_g2(cos_o, cos_i, alpha) / (4.0f * cos_o));
    }
    float3 ht = wo + eta * wi;
    float len2 = dot(ht, ht);
    if (!(len2 > 0.0f)) return (float3)(0.0f);
    float3 h = ht * rsqrt(len2);
    if (dot(n, h) < 0.0f) h = -h;
    float cos_oh = dot(wo, h), cos_ih = dot(wi, h);
    if (cos_oh <= 0.0f || cos_ih >= 0.0f) return (float3)(0.0f);
    float f = fresnel_dielectric(cos_oh, eta);
    float value = (1.0f - f) * ggx_d(n, h, alpha) * ggx_g2(cos_o, cos_i, alpha) * cos_oh * -cos_ih /
                  (cos_o * len2);
    return tint * value;
}

// Density of sample_dielectric: the visible-normal density, times the probability of the lobe
// chosen at that normal (F or 1 - F), times the Jacobian from h to wi (1 / (4 wo.h) for
// reflection; eta^2 |wi.h| / |wo + eta wi|^2 for refraction, Walter et al. eq. 17).
float sample_dielectric_pdf(float eta, float alpha, float3 n, float3 wo, float3 wi) {
    float cos_o = dot(n, wo), cos_i = dot(n, wi);
    if (cos_o <= 0.0f || cos_i == 0.0f) return 0.0f;
    if (cos_i > 0.0f) {
        float3 h = normalize(wo + wi);
        float cos_oh = dot(wo, h);
        float f = fresnel_dielectric(cos_oh, eta);
        return cos_oh > 0.0f ? f * sample_ggx_vndf_pdf(n, wo, h, alpha) / (4.0f * cos_oh) : 0.0f;
    }
    float3 ht = wo + eta * wi;
    float len2 = dot(ht, ht);
    if (!(len2 > 0.0f)) return 0.0f;
    float3 h = ht * rsqrt(len2);
    if (dot(n, h) < 0.0f) h = -h;
    float cos_oh = dot(wo, h), cos_ih = dot(wi, h);
    if (cos_oh <= 0.0f || cos_ih >= 0.0f) return 0.0f;
    float f = fresnel_dielectric(cos_oh, eta);
    return (1.0f - f) * sample_ggx_vndf_pdf(n, wo, h, alpha) * eta * eta * -cos_ih / len2;
}

// A visible microfacet normal, then reflection or refraction about it chosen by its Fresnel
// term. A direction that ends on the wrong side of the macro surface (reflected below it or
// refracted above it) is rejected rather than kept: otherwise two mechanisms could produce the
// same wi and sample_dielectric_pdf, which counts one, would understate the density.
// Returns the zero vector for no sample.
float3 sample_dielectric(float eta, float alpha, float3 n, float3 wo, float rnl, float2 rn) {
    float3 h = sample_ggx_vndf(n, wo, alpha, rn);
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
