// Conductors (metals): reflectance = tint x the Fresnel reflectance of a complex index of
// refraction eta + i k per RGB channel (Mitsuba 3's conductor and roughconductor), smooth (a
// delta lobe) or rough (a microfacet lobe: materials/microfacet.h, VNDF sampling). eta = k = 0
// is a perfect mirror, F = 1 (a conductor given only its tint).
// Conventions as in dielectric.h: unit world-space directions away from the surface, n on wo's
// side. Uses reflect() from dielectric_smooth.h; the smooth lobe and the Fresnel term are in
// conductor_smooth.h. Over the lane types (lanes.h).
#ifndef CLRENDER_CONDUCTOR_H
#define CLRENDER_CONDUCTOR_H
#include "lanes.h"
#include "math.h"
#include "materials/bsdf_sample.h"
#include "materials/microfacet.h"
#include "materials/dielectric_smooth.h"
#include "materials/conductor_smooth.h"
#if DIELECTRIC

// f * cos_i of the rough lobe and its sampler's density (sample_conductor: the visible-normal
// density times the Jacobian 1 / (4 wo.h) from h to wi), together: the half vector and D serve
// both (Mitsuba's eval_pdf).
lane_float3 eval_pdf_conductor(lane_float3 tint, lane_float3 eta, lane_float3 k, Microfacet mf, lane_float3 n,
                               lane_float3 wo, lane_float3 wi, lane_float* pdf_w) {
    lane_float cos_o = l3_dot(n, wo), cos_i = l3_dot(n, wi);
    lane_int lit = (cos_o > 0.0f) & (cos_i > 0.0f);
    *pdf_w = 0.0f;
    if (!lane_any(lit)) return l3_splat(0.0f);
    lane_float3 h = l3_normalize(l3_add(wo, wi));
    lane_float cos_oh = l3_dot(wo, h);
    lane_float d = microfacet_d(mf, n, h);
    lane_float3 f = fresnel_conductor(clamp(cos_oh, 0.0f, 1.0f), eta, k);
    lane_float g1_o = microfacet_g1(mf, cos_o);
    lane_float3 value = l3_scale(l3_mul(tint, f), d * microfacet_g_with_g1(mf, g1_o, cos_o, cos_i) / (4.0f * cos_o));
    lane_int visible = lit & (cos_oh > 0.0f);
    *pdf_w = select((lane_float)(0.0f), microfacet_visible_density(g1_o, cos_o, cos_oh, d) / (4.0f * cos_oh), visible);
    return l3_select(l3_splat(0.0f), value, lit);
}

lane_float3 eval_conductor(lane_float3 tint, lane_float3 eta, lane_float3 k, Microfacet mf, lane_float3 n,
                           lane_float3 wo, lane_float3 wi) {
    lane_float pdf_w;
    return eval_pdf_conductor(tint, eta, k, mf, n, wo, wi, &pdf_w);
}

lane_float sample_conductor_pdf(Microfacet mf, lane_float3 n, lane_float3 wo, lane_float3 wi) {
    lane_float pdf_w;
    eval_pdf_conductor(l3_splat(1.0f), l3_splat(0.0f), l3_splat(0.0f), mf, n, wo, wi, &pdf_w);
    return pdf_w;
}

// Zero vector for no sample (mirrored below the macro surface; see sample_dielectric).
lane_float3 sample_conductor(Microfacet mf, lane_float3 n, lane_float3 wo, lane_float2 rn) {
    lane_float3 wi = reflect(wo, sample_microfacet_visible(mf, n, wo, rn));
    return l3_select(l3_splat(0.0f), wi, l3_dot(n, wi) > 0.0f);
}

#endif
#endif
