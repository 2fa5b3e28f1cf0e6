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
// The rough interface is written over the lane types (lanes.h), as the smooth one.
#ifndef CLRENDER_DIELECTRIC_H
#define CLRENDER_DIELECTRIC_H
#include "lanes.h"
#include "math.h"
#include "materials/bsdf_sample.h"
#include "materials/microfacet.h"
#include "materials/dielectric_smooth.h"
#if DIELECTRIC

// ----- rough interface: microfacets (materials/microfacet.h) -------------------------------------
// Refraction's generalised half vector h ~ -(wo + eta wi) (Walter et al. 2007, eq. 16), turned to
// n's side, with |wo + eta wi|^2 and the cosines of wo and wi to h: false where no microfacet
// explains the pair (it must face wo and be crossed by wi).
lane_int refraction_half_vector(lane_float eta, lane_float3 n, lane_float3 wo, lane_float3 wi, lane_float3* h,
                                lane_float* len2, lane_float* cos_oh, lane_float* cos_ih) {
    lane_float3 ht = l3_add(wo, l3_scale(wi, eta));
    *len2 = l3_dot(ht, ht);
    *h = l3_scale(ht, rsqrt(*len2));
    *h = l3_select(*h, l3_neg(*h), l3_dot(n, *h) < 0.0f);
    *cos_oh = l3_dot(wo, *h);
    *cos_ih = l3_dot(wi, *h);
    return (*len2 > 0.0f) & (*cos_oh > 0.0f) & (*cos_ih < 0.0f);
}

// f * |cos_i| (Walter et al. 2007, eqs. 20-21) and its sampler's density (sample_dielectric:
// the visible-normal density, times the probability of the lobe chosen at that normal, F or
// 1 - F, times the Jacobian from h to wi, 1 / (4 wo.h) for reflection and
// eta^2 |wi.h| / |wo + eta wi|^2 for refraction, Walter et al. eq. 17), together: the half
// vector, Fresnel term, D and masking serve both (Mitsuba's eval_pdf). Reflection is tinted by
// reflect_tint (Mitsuba's specular_reflectance), transmission by tint (specular_transmittance).
// Since wo.h + eta wi.h = |wo + eta wi|, the squared denominator of eq. 21 is
// |wo + eta wi|^2 / eta^2, which never vanishes, and its eta^2 cancels the 1/eta^2 of radiance
// transport.
lane_float3 eval_pdf_dielectric(lane_float3 reflect_tint, lane_float3 tint, lane_float eta, Microfacet mf,
                                lane_float3 n, lane_float3 wo, lane_float3 wi, lane_float* pdf_w) {
    lane_float cos_o = l3_dot(n, wo), cos_i = l3_dot(n, wi);
    lane_int reflects = (cos_o > 0.0f) & (cos_i > 0.0f), transmits = (cos_o > 0.0f) & (cos_i < 0.0f);
    *pdf_w = 0.0f;
    // Reflection's half vector; |wo + wi| > 0 where it is used: both lie above the surface.
    lane_float3 h = l3_normalize(l3_add(wo, wi));
    lane_float len2 = 1.0f, cos_oh = l3_dot(wo, h), cos_ih = 0.0f;
    if (lane_any(transmits)) {
        lane_float3 h_t;
        lane_float len2_t, cos_oh_t, cos_ih_t;
        transmits &= refraction_half_vector(eta, n, wo, wi, &h_t, &len2_t, &cos_oh_t, &cos_ih_t);
        h = l3_select(h, h_t, transmits);
        len2 = select(len2, len2_t, transmits);
        cos_oh = select(cos_oh, cos_oh_t, transmits);
        cos_ih = select(cos_ih, cos_ih_t, transmits);
    }
    if (!lane_any(reflects | transmits)) return l3_splat(0.0f);
    lane_float f = fresnel_dielectric(cos_oh, eta);
    lane_float d = microfacet_d(mf, n, h);
    lane_float g1_o = microfacet_g1(mf, cos_o);
    lane_float g = microfacet_g_with_g1(mf, g1_o, cos_o, cos_i);
    lane_float visible = select((lane_float)(0.0f), microfacet_visible_density(g1_o, cos_o, cos_oh, d),
                               cos_oh > 0.0f);
    lane_float3 reflected = l3_scale(reflect_tint, f * d * g / (4.0f * cos_o));
    lane_float3 transmitted = l3_scale(tint, (1.0f - f) * d * g * cos_oh * -cos_ih / (cos_o * len2));
    *pdf_w = select(select((lane_float)(0.0f), (1.0f - f) * visible * eta * eta * -cos_ih / len2, transmits),
                    f * visible / (4.0f * cos_oh), reflects & (cos_oh > 0.0f));
    return l3_select(l3_select(l3_splat(0.0f), transmitted, transmits), reflected, reflects);
}

lane_float3 eval_dielectric(lane_float3 reflect_tint, lane_float3 tint, lane_float eta, Microfacet mf, lane_float3 n,
                            lane_float3 wo, lane_float3 wi) {
    lane_float pdf_w;
    return eval_pdf_dielectric(reflect_tint, tint, eta, mf, n, wo, wi, &pdf_w);
}

lane_float sample_dielectric_pdf(lane_float eta, Microfacet mf, lane_float3 n, lane_float3 wo, lane_float3 wi) {
    lane_float pdf_w;
    eval_pdf_dielectric(l3_splat(1.0f), l3_splat(1.0f), eta, mf, n, wo, wi, &pdf_w);
    return pdf_w;
}

// A visible microfacet normal, then reflection or refraction about it chosen by its Fresnel
// term (rnl). A direction that ends on the wrong side of the macro surface (reflected below it
// or refracted above it) is rejected rather than kept: otherwise two mechanisms could produce
// the same wi and sample_dielectric_pdf, which counts one, would understate the density.
// Returns the zero vector for no sample.
lane_float3 sample_dielectric(lane_float eta, Microfacet mf, lane_float3 n, lane_float3 wo, lane_float rnl,
                              lane_float2 rn) {
    lane_float3 h = sample_microfacet_visible(mf, n, wo, rn);
    lane_float cos_oh = l3_dot(wo, h);
    lane_int visible = cos_oh > 0.0f;
    lane_float3 wi = l3_splat(0.0f);
    if (!lane_any(visible)) return wi;
    lane_int reflects = visible & (rnl < fresnel_dielectric(cos_oh, eta));
    lane_int refracts = visible & !reflects;
    if (lane_any(reflects)) {
        lane_float3 r = reflect(wo, h);
        wi = l3_select(wi, r, reflects & (l3_dot(n, r) > 0.0f));
    }
    if (lane_any(refracts)) {
        lane_float3 t = l3_splat(0.0f);
        refracts &= refract(wo, h, eta, &t);
        wi = l3_select(wi, t, refracts & (l3_dot(n, t) < 0.0f));
    }
    return wi;
}

#endif
#endif
