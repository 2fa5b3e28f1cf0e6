// Microfacet surfaces as the rough lobes see them: one small interface over the distributions
// of normals (materials/ggx.h, materials/beckmann.h). A Microfacet names the distribution
// (MICROFACET_GGX, MICROFACET_BECKMANN), its width alpha, and how masking and shadowing combine
// (MASKING_HEIGHT_CORRELATED: Heitz 2014's G2, our default; MASKING_SEPARABLE: G1(wo) G1(wi),
// as Mitsuba 3's rough BSDFs). The enumerations come from clrender/layout.py.
// Directions are unit vectors in world space; n is the macro normal on wo's side.
#ifndef CLRENDER_MICROFACET_H
#define CLRENDER_MICROFACET_H
#include "math.h"
#include "materials/material.h"
#include "materials/ggx.h"
#include "materials/beckmann.h"
#if DIELECTRIC

typedef struct {
    float alpha;
    int distribution;   // MICROFACET_*
    int masking;        // MASKING_*
} Microfacet;

Microfacet make_microfacet(float alpha, int distribution, int masking) {
    Microfacet mf;
    mf.alpha = alpha;
    mf.distribution = distribution;
    mf.masking = masking;
    return mf;
}

// The microfacet surface of a rough material (fields alpha, distribution, masking).
Microfacet material_microfacet(const Material* m) {
    return make_microfacet(material_alpha(m), material_distribution(m), material_masking(m));
}

// Below this width a lobe is narrower than float32 can evaluate reliably (a GGX D peaks at
// 1 / (pi alpha^2) and 1 - cos^2 cancels near the peak); such surfaces are treated as smooth,
// as in pbrt-v4 (TrowbridgeReitzDistribution::EffectivelySmooth).
#define MICROFACET_MIN_ALPHA 1e-3f

bool microfacet_is_smooth(float alpha) { return alpha < MICROFACET_MIN_ALPHA; }

// The distribution of normals D(h), per unit solid angle and projected area.
float microfacet_d(Microfacet mf, float3 n, float3 h) {
    return mf.distribution == MICROFACET_BECKMANN ? beckmann_d(n, h, mf.alpha) : ggx_d(n, h, mf.alpha);
}

// Smith masking of one direction at cos_w to the macro normal.
float microfacet_g1(Microfacet mf, float cos_w) {
    return mf.distribution == MICROFACET_BECKMANN ? beckmann_g1(cos_w, mf.alpha) : ggx_g1(cos_w, mf.alpha);
}

// Masking-shadowing of the pair (wo, wi), from their cosines to the macro normal (either sign:
// transmission has cos_i < 0). The microfacet must face both; the lobes check that.
float microfacet_g(Microfacet mf, float cos_o, float cos_i) {
    if (mf.masking == MASKING_SEPARABLE) return microfacet_g1(mf, cos_o) * microfacet_g1(mf, cos_i);
    return mf.distribution == MICROFACET_BECKMANN ? beckmann_g2(cos_o, cos_i, mf.alpha)
                                                   : ggx_g2(cos_o, cos_i, mf.alpha);
}

// Density of visible normals, per unit solid angle of h (Heitz 2018, eq. 3):
// D_wo(h) = G1(wo) max(0, wo.h) D(h) / cos_o.
float sample_microfacet_visible_pdf(Microfacet mf, float3 n, float3 wo, float3 h) {
    float cos_o = dot(n, wo), cos_oh = dot(wo, h);
    if (cos_o <= 0.0f || cos_oh <= 0.0f) return 0.0f;
    return microfacet_g1(mf, cos_o) * cos_oh * microfacet_d(mf, n, h) / cos_o;
}

// A microfacet normal visible from wo, distributed as sample_microfacet_visible_pdf. (Mitsuba's
// sample_visible = false samples D(h) cos(h) instead: the same lobes in expectation, noisier;
// we always sample visible normals.)
float3 sample_microfacet_visible(Microfacet mf, float3 n, float3 wo, float2 u) {
    return mf.distribution == MICROFACET_BECKMANN ? sample_beckmann_vndf(n, wo, mf.alpha, u)
                                                   : sample_ggx_vndf(n, wo, mf.alpha, u);
}

#endif
#endif
