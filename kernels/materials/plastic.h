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

typedef struct {
    float3 diffuse;         // diffuse_reflectance of the base
    float3 specular;        // specular_reflectance of the coat
    Microfacet mf;          // the rough coat's microfacets (separable masking: Mitsuba's)
    float specular_weight;  // specular_sampling_weight
    int nonlinear;
    int mirror;             // the specular lobe is a delta lobe
    PlasticCoat coat;
} Plastic;

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

// The probability of the specular lobe for wo at cos_o.
float plastic_specular_probability(const Plastic* p, float cos_o) {
    float t = coat_transmittance(&p->coat, cos_o);
    float specular = (1.0f - t) * p->specular_weight, diffuse = t * (1.0f - p->specular_weight);
    return specular + diffuse > 0.0f ? specular / (specular + diffuse) : p->specular_weight;
}

float3 eval_plastic(const Plastic* p, float3 n, float3 wo, float3 wi) {
    float cos_o = dot(n, wo), cos_i = dot(n, wi);
    if (cos_o <= 0.0f || cos_i <= 0.0f) return (float3)(0.0f);
    const PlasticCoat* c = &p->coat;
    float r = coat_internal_reflectance(c);
    float3 internal = p->nonlinear ? p->diffuse * r : (float3)(r);
    float3 value = p->diffuse / (1.0f - internal) *
        (cos_i * INV_PI_F / (c->eta * c->eta) * coat_transmittance(c, cos_o) * coat_transmittance(c, cos_i));
    if (p->mirror) return value;  // a delta lobe
    float3 h = normalize(wo + wi);
    float specular = fresnel_dielectric(dot(wo, h), c->eta) * microfacet_d(p->mf, n, h) *
                     microfacet_g(p->mf, cos_o, cos_i) / (4.0f * cos_o);
    return value + specular * p->specular;
}

// Density of sample_plastic (without a mirror, a delta lobe).
float sample_plastic_pdf(const Plastic* p, float3 n, float3 wo, float3 wi) {
    float cos_o = dot(n, wo), cos_i = dot(n, wi);
    if (cos_o <= 0.0f || cos_i <= 0.0f) return 0.0f;
    float specular = plastic_specular_probability(p, cos_o);
    float pdf = (1.0f - specular) * sample_cosine_hemisphere_pdf_w(cos_i);
    if (p->mirror) return pdf;
    float3 h = normalize(wo + wi);
    float cos_oh = dot(wo, h);
    return cos_oh > 0.0f ? pdf + specular * sample_microfacet_visible_pdf(p->mf, n, wo, h) / (4.0f * cos_oh) : pdf;
}

// ng: the geometric normal on wo's side (for the mirror, as sample_conductor_delta). A glossy
// or diffuse sample weighs eval / pdf of its direction; the zero vector with pdf 0 is no sample.
BsdfSample sample_plastic(const Plastic* p, float3 n, float3 ng, float3 wo, float rnl, float2 rn) {
    float cos_o = dot(n, wo);
    if (cos_o <= 0.0f) return bsdf_sample_none();
    float specular = plastic_specular_probability(p, cos_o);
    bool glossy = rnl < specular;
    if (glossy && p->mirror) {
        float f = 1.0f - coat_transmittance(&p->coat, cos_o);
        // A perfect mirror (index 0 + 0i: Fresnel 1) of the coat's reflectance.
        BsdfSample bs = sample_conductor_delta(p->specular * (f / specular), (float3)(0.0f), (float3)(0.0f), n, ng, wo);
        bs.pdf_w = specular;
        return bs;
    }
    BsdfSample bs = bsdf_sample_none();
    bs.wi = glossy ? reflect(wo, sample_microfacet_visible(p->mf, n, wo, rn)) : to_world(sample_cosine_hemisphere(rn), n);
    bs.pdf_w = sample_plastic_pdf(p, n, wo, bs.wi);
    if (bs.pdf_w > 0.0f) bs.weight = eval_plastic(p, n, wo, bs.wi) / bs.pdf_w;
    return bs;
}

#endif
#endif
