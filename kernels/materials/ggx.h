// The GGX (Trowbridge-Reitz) distribution of microfacet normals, isotropic: D, Smith's masking G1,
// height-correlated masking-shadowing G2 and sampling of the normals visible from wo (VNDF).
// Directions are unit vectors in world space; n is the macro normal on wo's side; alpha is the
// GGX width. The rough lobes reach it through materials/microfacet.h.
#ifndef CLRENDER_GGX_H
#define CLRENDER_GGX_H
#include "math.h"
#if DIELECTRIC

// D(h) = alpha^2 / (pi (cos^2 alpha^2 + sin^2)^2) (Walter et al. 2007, eq. 33). sin^2 comes from
// a cross product, not 1 - cos^2, which would cancel to zero near the peak of a narrow lobe.
float ggx_d(float3 n, float3 h, float alpha) {
    float cos_h = dot(n, h);
    if (cos_h <= 0.0f) return 0.0f;
    float3 c = cross(n, h);
    float a2 = alpha * alpha;
    float k = cos_h * cos_h * a2 + dot(c, c);
    return a2 / (PI_F * k * k);
}

// sqrt(cos^2 + alpha^2 sin^2): the term shared by Lambda and G1. With it,
// Lambda = (s / |cos| - 1) / 2, written so that cos -> 0 gives 0 masking, never inf / inf.
float ggx_mask_term(float cos_w, float alpha) {
    float c2 = cos_w * cos_w;
    return sqrt(c2 + alpha * alpha * fmax(0.0f, 1.0f - c2));
}

// Smith masking of one direction: G1 = 1 / (1 + Lambda) = 2 |cos| / (|cos| + s).
float ggx_g1(float cos_w, float alpha) {
    float c = fabs(cos_w);
    float d = c + ggx_mask_term(c, alpha);
    return d > 0.0f ? 2.0f * c / d : 0.0f;
}

// Height-correlated masking-shadowing (Heitz 2014, "Understanding the Masking-Shadowing
// Function", eq. 99): G2 = 1 / (1 + Lambda_o + Lambda_i) = 2 co ci / (co si + ci so).
float ggx_g2(float cos_o, float cos_i, float alpha) {
    float co = fabs(cos_o), ci = fabs(cos_i);
    float d = co * ggx_mask_term(ci, alpha) + ci * ggx_mask_term(co, alpha);
    return d > 0.0f ? 2.0f * co * ci / d : 0.0f;
}

// A microfacet normal visible from wo, distributed as sample_microfacet_visible_pdf (Heitz 2018,
// "Sampling the GGX Distribution of Visible Normals", listing 1): stretch wo to the unit-roughness
// configuration, sample the projected hemisphere there, unstretch.
float3 sample_ggx_vndf(float3 n, float3 wo, float alpha, float2 u) {
    float3 t, b;
    make_basis(n, &t, &b);
    float3 vh = normalize((float3)(alpha * dot(wo, t), alpha * dot(wo, b), fmax(dot(wo, n), 0.0f)));
    float len2 = vh.x * vh.x + vh.y * vh.y;
    // At normal incidence any tangent will do; rsqrt(0) would be inf.
    float3 t1 = len2 > 0.0f ? (float3)(-vh.y, vh.x, 0.0f) * rsqrt(len2) : (float3)(1.0f, 0.0f, 0.0f);
    float3 t2 = cross(vh, t1);
    float r = sqrt(u.x);
    float s_phi, c_phi;
    sincos_2pi(u.y, &s_phi, &c_phi);
    float p1 = r * c_phi, p2 = r * s_phi;
    float s = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - s) * sqrt(fmax(0.0f, 1.0f - p1 * p1)) + s * p2;
    float3 nh = p1 * t1 + p2 * t2 + sqrt(fmax(0.0f, 1.0f - p1 * p1 - p2 * p2)) * vh;
    float3 hl = normalize((float3)(alpha * nh.x, alpha * nh.y, fmax(nh.z, 0.0f)));
    return hl.x * t + hl.y * b + hl.z * n;
}

#endif
#endif
