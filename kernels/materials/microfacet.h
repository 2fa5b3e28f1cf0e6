// Microfacet surfaces as the rough lobes see them: one small interface over the distributions
// of normals (materials/ggx.h, materials/beckmann.h). A Microfacet names the distribution
// (MICROFACET_GGX, MICROFACET_BECKMANN), its width alpha, and how masking and shadowing combine
// (MASKING_HEIGHT_CORRELATED: Heitz 2014's G2, our default; MASKING_SEPARABLE: G1(wo) G1(wi),
// as Mitsuba 3's rough BSDFs). The enumerations come from clrender/layout.py.
// Directions are unit vectors in world space; n is the macro normal on wo's side.
#ifndef CLRENDER_MICROFACET_H
#define CLRENDER_MICROFACET_H
#include "lanes.h"
#include "math.h"
#include "materials/material.h"
#include "materials/ggx.h"
#include "materials/beckmann.h"
#if DIELECTRIC

// Over the lane types (lanes.h): each lane its surface; a lane's distribution is one of the two,
// and a branch skips the one no lane has.
typedef struct {
    lane_float alpha;
    lane_int distribution;   // MICROFACET_*
    lane_int masking;        // MASKING_*
} Microfacet;

Microfacet make_microfacet(lane_float alpha, lane_int distribution, lane_int masking) {
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

// The same, of each lane's material `index` (lanes.h).
Microfacet material_microfacet_at(__global const Material* materials, lane_int index) {
    return make_microfacet(material_alpha_at(materials, index), material_distribution_at(materials, index),
                           material_masking_at(materials, index));
}

// mf with the lanes outside `lanes` (whose values are discarded) given the distribution and the
// masking that every lane of `lanes` shares, where they share one: the functions below branch on
// whether any lane takes each kind, and a packet's lanes without a glossy lobe (a diffuse
// donut's, default GGX and height-correlated) made them evaluate both.
Microfacet microfacet_of_lanes(Microfacet mf, lane_int lanes) {
    lane_int beckmann = mf.distribution == MICROFACET_BECKMANN, separable = mf.masking == MASKING_SEPARABLE;
    if (!lane_any(lanes & !beckmann)) mf.distribution = select(mf.distribution, (lane_int)(MICROFACET_BECKMANN), !lanes);
    if (!lane_any(lanes & beckmann)) mf.distribution = select(mf.distribution, (lane_int)(MICROFACET_GGX), !lanes);
    if (!lane_any(lanes & !separable)) mf.masking = select(mf.masking, (lane_int)(MASKING_SEPARABLE), !lanes);
    if (!lane_any(lanes & separable)) mf.masking = select(mf.masking, (lane_int)(MASKING_HEIGHT_CORRELATED), !lanes);
    return mf;
}

// Below this width a lobe is narrower than float32 can evaluate reliably (a GGX D peaks at
// 1 / (pi alpha^2) and 1 - cos^2 cancels near the peak); such surfaces are treated as smooth,
// as in pbrt-v4 (TrowbridgeReitzDistribution::EffectivelySmooth).
#define MICROFACET_MIN_ALPHA 1e-3f

bool microfacet_is_smooth(float alpha) { return alpha < MICROFACET_MIN_ALPHA; }

// A glossy lobe counts only where the geometric and the shading normal put wi on the same side
// (a, b: wi's cosines to them), as eval_diffuse does; otherwise light would leak through the facet.
lane_int sides_agree(lane_float a, lane_float b) { return ((a > 0.0f) & (b > 0.0f)) | ((a < 0.0f) & (b < 0.0f)); }

// `beckmann` of the lanes, `ggx` of the others: each evaluated only where some lane needs it.
#define MICROFACET_EITHER(mf, beckmann, ggx) \
    lane_int is_beckmann = (mf).distribution == MICROFACET_BECKMANN; \
    lane_float value = 0.0f; \
    if (lane_any(is_beckmann)) value = (beckmann); \
    if (lane_any(!is_beckmann)) value = select(value, (ggx), !is_beckmann); \
    return value;

// The distribution of normals D(h), per unit solid angle and projected area.
lane_float microfacet_d(Microfacet mf, lane_float3 n, lane_float3 h) {
    MICROFACET_EITHER(mf, beckmann_d(n, h, mf.alpha), ggx_d(n, h, mf.alpha))
}

// Smith masking of one direction at cos_w to the macro normal.
lane_float microfacet_g1(Microfacet mf, lane_float cos_w) {
    MICROFACET_EITHER(mf, beckmann_g1(cos_w, mf.alpha), ggx_g1(cos_w, mf.alpha))
}

// Height-correlated masking-shadowing of the pair (wo, wi), either distribution.
lane_float microfacet_g2(Microfacet mf, lane_float cos_o, lane_float cos_i) {
    MICROFACET_EITHER(mf, beckmann_g2(cos_o, cos_i, mf.alpha), ggx_g2(cos_o, cos_i, mf.alpha))
}

// Masking-shadowing of the pair (wo, wi), from their cosines to the macro normal (either sign:
// transmission has cos_i < 0), with wo's masking g1_o = microfacet_g1(mf, cos_o) at hand: the
// lobes' eval_pdf compute it once for this and for the visible-normal density. The microfacet
// must face both directions; the lobes check that.
lane_float microfacet_g_with_g1(Microfacet mf, lane_float g1_o, lane_float cos_o, lane_float cos_i) {
    lane_int separable = mf.masking == MASKING_SEPARABLE;
    lane_float g = 0.0f;
    if (lane_any(separable)) g = g1_o * microfacet_g1(mf, cos_i);
    if (lane_any(!separable)) g = select(g, microfacet_g2(mf, cos_o, cos_i), !separable);
    return g;
}

lane_float microfacet_g(Microfacet mf, lane_float cos_o, lane_float cos_i) {
    lane_int separable = mf.masking == MASKING_SEPARABLE;
    lane_float g1_o = 0.0f;   // only the separable product needs it
    if (lane_any(separable)) g1_o = microfacet_g1(mf, cos_o);
    return microfacet_g_with_g1(mf, g1_o, cos_o, cos_i);
}

// Density of visible normals, per unit solid angle of h (Heitz 2018, eq. 3):
// D_wo(h) = G1(wo) max(0, wo.h) D(h) / cos_o, from G1(wo) and D(h) (the lobes' eval_pdf have
// both at hand), where cos_o > 0 and cos_oh > 0.
lane_float microfacet_visible_density(lane_float g1_o, lane_float cos_o, lane_float cos_oh, lane_float d) {
    return g1_o * cos_oh * d / cos_o;
}

// The same at the microfacet normal h, 0 where wo does not see it.
lane_float sample_microfacet_visible_pdf(Microfacet mf, lane_float3 n, lane_float3 wo, lane_float3 h) {
    lane_float cos_o = l3_dot(n, wo), cos_oh = l3_dot(wo, h);
    lane_int visible = (cos_o > 0.0f) & (cos_oh > 0.0f);
    if (!lane_any(visible)) return 0.0f;
    return select((lane_float)(0.0f),
                  microfacet_visible_density(microfacet_g1(mf, cos_o), cos_o, cos_oh, microfacet_d(mf, n, h)), visible);
}

// A microfacet normal visible from wo, distributed as sample_microfacet_visible_pdf. (Mitsuba's
// sample_visible = false samples D(h) cos(h) instead: the same lobes in expectation, noisier;
// we always sample visible normals.)
lane_float3 sample_microfacet_visible(Microfacet mf, lane_float3 n, lane_float3 wo, lane_float2 u) {
    lane_int is_beckmann = mf.distribution == MICROFACET_BECKMANN;
    lane_float3 h = l3_splat(0.0f);
    if (lane_any(is_beckmann)) h = sample_beckmann_vndf(n, wo, mf.alpha, u);
    if (lane_any(!is_beckmann)) h = l3_select(h, sample_ggx_vndf(n, wo, mf.alpha, u), !is_beckmann);
    return h;
}

#endif
#endif
