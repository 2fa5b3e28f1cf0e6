// The GGX (Trowbridge-Reitz) distribution of microfacet normals, isotropic: D, Smith's masking G1,
// height-correlated masking-shadowing G2 and sampling of the normals visible from wo (VNDF).
// Directions are unit vectors in world space; n is the macro normal on wo's side; alpha is the
// GGX width. Written over the lane types (lanes.h); the rough lobes reach it through
// materials/microfacet.h.
#ifndef CLRENDER_GGX_H
#define CLRENDER_GGX_H
#include "lanes.h"
#include "math.h"
#if DIELECTRIC

// D(h) = alpha^2 / (pi (cos^2 alpha^2 + sin^2)^2) (Walter et al. 2007, eq. 33). sin^2 comes from
// a cross product, not 1 - cos^2, which would cancel to zero near the peak of a narrow lobe.
lane_float ggx_d(lane_float3 n, lane_float3 h, lane_float alpha) {
    lane_float cos_h = l3_dot(n, h);
    lane_float3 c = l3_cross(n, h);
    lane_float a2 = alpha * alpha;
    lane_float k = cos_h * cos_h * a2 + l3_dot(c, c);
    return select((lane_float)(0.0f), a2 / (PI_F * k * k), cos_h > 0.0f);
}

// sqrt(cos^2 + alpha^2 sin^2): the term shared by Lambda and G1. With it,
// Lambda = (s / |cos| - 1) / 2, written so that cos -> 0 gives 0 masking, never inf / inf.
lane_float ggx_mask_term(lane_float cos_w, lane_float alpha) {
    lane_float c2 = cos_w * cos_w;
    return sqrt(c2 + alpha * alpha * fmax(0.0f, 1.0f - c2));
}

// Smith masking of one direction: G1 = 1 / (1 + Lambda) = 2 |cos| / (|cos| + s).
lane_float ggx_g1(lane_float cos_w, lane_float alpha) {
    lane_float c = fabs(cos_w);
    lane_float d = c + ggx_mask_term(c, alpha);
    return select((lane_float)(0.0f), 2.0f * c / d, d > 0.0f);
}

// Height-correlated masking-shadowing (Heitz 2014, "Understanding the Masking-Shadowing
// Function", eq. 99): G2 = 1 / (1 + Lambda_o + Lambda_i) = 2 co ci / (co si + ci so).
lane_float ggx_g2(lane_float cos_o, lane_float cos_i, lane_float alpha) {
    lane_float co = fabs(cos_o), ci = fabs(cos_i);
    lane_float d = co * ggx_mask_term(ci, alpha) + ci * ggx_mask_term(co, alpha);
    return select((lane_float)(0.0f), 2.0f * co * ci / d, d > 0.0f);
}

// A microfacet normal visible from wo, distributed as sample_microfacet_visible_pdf (Heitz 2018,
// "Sampling the GGX Distribution of Visible Normals", listing 1): stretch wo to the unit-roughness
// configuration, sample the projected hemisphere there, unstretch.
lane_float3 sample_ggx_vndf(lane_float3 n, lane_float3 wo, lane_float alpha, lane_float2 u) {
    lane_float3 t, b;
    make_basis(n, &t, &b);
    lane_float3 vh = l3_normalize(make_lane_float3(alpha * l3_dot(wo, t), alpha * l3_dot(wo, b),
                                                   fmax(l3_dot(wo, n), 0.0f)));
    lane_float len2 = vh.x * vh.x + vh.y * vh.y;
    // At normal incidence any tangent will do; rsqrt(0) would be inf.
    lane_int tilted = len2 > 0.0f;
    lane_float inv_len = rsqrt(select((lane_float)(1.0f), len2, tilted));
    lane_float3 t1 = make_lane_float3(select((lane_float)(1.0f), -vh.y * inv_len, tilted),
                                      select((lane_float)(0.0f), vh.x * inv_len, tilted), (lane_float)(0.0f));
    lane_float3 t2 = l3_cross(vh, t1);
    lane_float r = sqrt(u.x);
    lane_float s_phi, c_phi;
    sincos_2pi(u.y, &s_phi, &c_phi);
    lane_float p1 = r * c_phi, p2 = r * s_phi;
    lane_float s = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - s) * sqrt(fmax(0.0f, 1.0f - p1 * p1)) + s * p2;
    lane_float3 nh = l3_add(l3_add(l3_scale(t1, p1), l3_scale(t2, p2)),
                            l3_scale(vh, sqrt(fmax(0.0f, 1.0f - p1 * p1 - p2 * p2))));
    lane_float3 hl = l3_normalize(make_lane_float3(alpha * nh.x, alpha * nh.y, fmax(nh.z, 0.0f)));
    return l3_add(l3_add(l3_scale(t, hl.x), l3_scale(b, hl.y)), l3_scale(n, hl.z));
}

#endif
#endif
