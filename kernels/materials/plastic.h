// Plastic: Mitsuba 3.9's `plastic` (a smooth coat) and `roughplastic` (a rough one: the material
// has coat tables), one material kind: a diffuse base (`diffuse_reflectance`, the field color)
// under a dielectric coat of relative index eta = int_ior / ext_ior (materials/plastic_coat.h),
// reflection only. Two lobes, f * cos_i:
//   specular: the coat's reflection tinted by `specular_reflectance`: a mirror of weight
//     1 - T(cos_o) (a smooth coat, or a rough one narrower than MICROFACET_MIN_ALPHA), or
//     F D G1(wo) G1(wi) / (4 cos_o) (rough: Mitsuba's separable masking);
//   diffuse: diffuse / (1 - r) / (pi eta^2) T(cos_o) T(cos_i) cos_i. Light crosses the coat (T)
//     twice; of what the base scatters up the coat reflects r back down, to scatter again: the
//     series 1 / (1 - diffuse r) per channel with `nonlinear`, Mitsuba's default 1 / (1 - r)
//     otherwise; 1 / eta^2: radiance leaving the denser coat spreads over a wider solid angle.
// The specular lobe is picked with probability (1 - T(cos_o)) w / ((1 - T(cos_o)) w + T(cos_o)
// (1 - w)), w the field specular_sampling_weight (Mitsuba's: mean specular / (mean specular +
// mean diffuse)), sampled by visible normals; the diffuse lobe by the cosine. Neither conserves
// energy exactly (Mitsuba's model: T and r are single-scattering quantities).
// Conventions as in dielectric.h: unit world-space directions away from the surface, n the
// normal on wo's side (wo: towards the viewer, Mitsuba's si.wi).
#ifndef CLRENDER_PLASTIC_H
#define CLRENDER_PLASTIC_H
#include "lanes.h"
#include "math.h"
#include "sampling.h"
#include "scene.h"
#include "materials/material.h"
#include "materials/bsdf_sample.h"
#include "materials/microfacet.h"
#include "materials/dielectric_smooth.h"
#include "materials/conductor.h"
#include "materials/plastic_coat.h"
#if DIELECTRIC

// Over the lane types (lanes.h): each lane its plastic.
typedef struct {
    lane_float3 diffuse;         // diffuse_reflectance of the base
    lane_float3 specular;        // specular_reflectance of the coat
    Microfacet mf;               // the rough coat's microfacets (separable masking: Mitsuba's)
    lane_float specular_weight;  // specular_sampling_weight
    lane_int nonlinear;
    lane_int mirror;             // the specular lobe is a delta lobe
    PlasticCoat coat;
} Plastic;

#if LANES == 1
// The plastic of material m, its textures resolved.
Plastic plastic_at(const Scene* scene, const Material* m) {
    Plastic p;
    p.diffuse = material_color(m);
    p.specular = material_reflection_tint(m);
    p.mf = material_microfacet(m);
    p.specular_weight = material_specular_sampling_weight(m);
    p.nonlinear = material_nonlinear(m);
    p.coat = plastic_coat(scene, m, p.mf.alpha);
    p.mirror = p.coat.smooth || microfacet_is_smooth(p.mf.alpha);
    return p;
}
#endif

// The plastic of each lane's material `index` where `plastic`, of base colour `diffuse` (its
// texture's value: the packets resolve no other parameter from textures, features.py) and
// microfacets mf (material_microfacet_at, which the caller has).
Plastic plastic_lanes(const Scene* scene, lane_int index, lane_int plastic, lane_float3 diffuse, Microfacet mf) {
    Plastic p;
    p.diffuse = diffuse;
    p.specular = material_reflection_tint_at(scene->materials, index);
    p.mf = mf;
    p.specular_weight = material_specular_sampling_weight_at(scene->materials, index);
    p.nonlinear = material_nonlinear_at(scene->materials, index);
    p.coat = plastic_coat_at(scene, index, plastic, p.mf.alpha);
    p.mirror = p.coat.smooth | (p.mf.alpha < MICROFACET_MIN_ALPHA);   // microfacet_is_smooth
    return p;
}

// The probability of the specular lobe, from the coat's transmittance t_o towards wo.
lane_float plastic_specular_probability(const Plastic* p, lane_float t_o) {
    lane_float specular = (1.0f - t_o) * p->specular_weight, diffuse = t_o * (1.0f - p->specular_weight);
    return select(p->specular_weight, specular / (specular + diffuse), specular + diffuse > 0.0f);
}

// f * cos_i of wi and (*pdf_w) the density of sample_plastic's drawing it (without the mirror, a
// delta lobe, which has neither): the coat's transmittance towards wo, the half vector and D
// serve both (as eval_pdf_dielectric).
lane_float3 eval_pdf_plastic(const Plastic* p, lane_float3 n, lane_float3 wo, lane_float3 wi, lane_float* pdf_w) {
    lane_float cos_o = l3_dot(n, wo), cos_i = l3_dot(n, wi);
    lane_int lit = (cos_o > 0.0f) & (cos_i > 0.0f);
    *pdf_w = 0.0f;
    if (!lane_any(lit)) return l3_splat(0.0f);
    const PlasticCoat* c = &p->coat;
    lane_float t_o = coat_transmittance(c, cos_o);
    lane_float r = coat_internal_reflectance(c);
    lane_float3 internal = l3_select(make_lane_float3(r, r, r), l3_scale(p->diffuse, r), p->nonlinear != 0);
    lane_float3 value = l3_scale(l3_div3(p->diffuse, l3_sub(l3_splat(1.0f), internal)),
        cos_i * INV_PI_F / (c->eta * c->eta) * t_o * coat_transmittance(c, cos_i));
    lane_float specular = plastic_specular_probability(p, t_o);
    lane_float pdf = (1.0f - specular) * sample_cosine_hemisphere_pdf_w(cos_i);
    lane_int glossy = lit & !(p->mirror != 0);
    if (lane_any(glossy)) {
        lane_float3 h = l3_normalize(l3_add(wo, wi));
        lane_float cos_oh = l3_dot(wo, h);
        lane_float d = microfacet_d(p->mf, n, h);
        lane_float g1_o = microfacet_g1(p->mf, cos_o);
        lane_float coat = fresnel_dielectric(cos_oh, c->eta) * d * microfacet_g_with_g1(p->mf, g1_o, cos_o, cos_i) /
                          (4.0f * cos_o);
        value = l3_select(value, l3_madd(p->specular, coat, value), glossy);
        lane_int visible = glossy & (cos_oh > 0.0f);
        pdf = select(pdf, pdf + specular * microfacet_visible_density(g1_o, cos_o, cos_oh, d) / (4.0f * cos_oh), visible);
    }
    *pdf_w = select((lane_float)(0.0f), pdf, lit);
    return l3_select(l3_splat(0.0f), value, lit);
}

lane_float3 eval_plastic(const Plastic* p, lane_float3 n, lane_float3 wo, lane_float3 wi) {
    lane_float pdf_w;
    return eval_pdf_plastic(p, n, wo, wi, &pdf_w);
}

// Density of sample_plastic (without a mirror, a delta lobe).
lane_float sample_plastic_pdf(const Plastic* p, lane_float3 n, lane_float3 wo, lane_float3 wi) {
    lane_float pdf_w;
    eval_pdf_plastic(p, n, wo, wi, &pdf_w);
    return pdf_w;
}

// ng: the geometric normal on wo's side (for the mirror, as sample_conductor_delta). A glossy
// or diffuse sample weighs eval / pdf of its direction; the zero vector with pdf 0 is no sample.
BsdfSample sample_plastic(const Plastic* p, lane_float3 n, lane_float3 ng, lane_float3 wo, lane_float rnl,
                          lane_float2 rn) {
    BsdfSample bs = bsdf_sample_none();
    lane_float cos_o = l3_dot(n, wo);
    lane_int valid = cos_o > 0.0f;
    if (!lane_any(valid)) return bs;
    lane_float t_o = coat_transmittance(&p->coat, cos_o);
    lane_float specular = plastic_specular_probability(p, t_o);
    lane_int glossy = rnl < specular;
    lane_int mirror = valid & glossy & (p->mirror != 0);
    if (lane_any(mirror)) {
        lane_float f = 1.0f - t_o;
        // A perfect mirror (index 0 + 0i: Fresnel 1) of the coat's reflectance.
        BsdfSample reflected = sample_conductor_delta(l3_scale(p->specular, f / specular), l3_splat(0.0f),
                                                      l3_splat(0.0f), n, ng, wo);
        bs.wi = l3_select(bs.wi, reflected.wi, mirror);
        bs.weight = l3_select(bs.weight, reflected.weight, mirror);
        bs.pdf_w = select(bs.pdf_w, specular, mirror);
        bs.delta = select(bs.delta, reflected.delta, mirror);
    }
    lane_int rough = valid & glossy & !mirror, diffuse = valid & !glossy;
    if (!lane_any(rough | diffuse)) return bs;
    lane_float3 wi = l3_splat(0.0f);
    if (lane_any(diffuse)) wi = l3_select(wi, to_world(sample_cosine_hemisphere(rn), n), diffuse);
    if (lane_any(rough)) wi = l3_select(wi, reflect(wo, sample_microfacet_visible(p->mf, n, wo, rn)), rough);
    lane_float pdf_w;
    lane_float3 f = eval_pdf_plastic(p, n, wo, wi, &pdf_w);
    lane_int sampled = (rough | diffuse) & (pdf_w > 0.0f);
    bs.wi = l3_select(bs.wi, wi, rough | diffuse);
    bs.pdf_w = select(bs.pdf_w, pdf_w, rough | diffuse);
    if (lane_any(sampled)) bs.weight = l3_select(bs.weight, l3_div(f, pdf_w), sampled);
    return bs;
}

#endif
#endif
