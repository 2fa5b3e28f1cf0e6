// Dispatch over material kinds. Only the kinds compiled in by feature defines appear here.
// eval_bsdf returns f * |cos| and may be non-zero on either side of the surface (transmission);
// sample_bsdf_pdf is the solid-angle density of sample_bsdf, 0 for delta lobes. The scene
// supplies the energy-compensation tables of rough lobes (materials/energy.h).
#ifndef CLRENDER_BSDF_H
#define CLRENDER_BSDF_H
#include "math.h"
#include "rng.h"
#include "scene.h"
#include "materials/material.h"
#include "materials/bsdf_sample.h"
#include "materials/diffuse.h"
#include "materials/microfacet.h"
#include "materials/dielectric.h"
#include "materials/conductor.h"
#include "materials/thin_dielectric.h"
#include "materials/energy.h"
#include "materials/plastic.h"
#include "materials/principled.h"

#if DIELECTRIC
// Entering or leaving is decided by the geometric normal and the ray (sp->front_face, i.e. the
// triangle's winding faces the ray): the relative index is inverted on the way out.
float material_eta(const Material* m, const SurfacePoint* sp) {
    float ior = material_ior(m), exterior = material_exterior_ior(m);
    return sp->front_face ? ior / exterior : exterior / ior;
}

// The normal the specular models use: the shading normal, unless wo is below its tangent plane
// (interpolated normals bend away from the facet near silhouettes); then the facet's.
float3 specular_normal(const SurfacePoint* sp, float3 wo) {
    return dot(wo, sp->ns) > 0.0f ? sp->ns : sp->ng;
}

// Energy compensation of a rough lobe at this wo (materials/energy.h); 1 for smooth lobes,
// whose material has no table (albedo_tables < 0).
float3 specular_energy_scale(const Scene* scene, const Material* m, const SurfacePoint* sp,
                             float cos_o) {
    int offset = material_albedo_tables(m);
    if (offset < 0) return (float3)(1.0f);
    bool dielectric = material_kind(m) == MATERIAL_DIELECTRIC;
    int side = dielectric && !sp->front_face ? ALBEDO_TABLE_SIZE : 0;
    float e = lookup_albedo(scene->specular_albedo + offset + side, cos_o);
    if (!(e > 0.0f)) return (float3)(1.0f);
    if (dielectric) return (float3)(1.0f / e);
    float3 f0 = fresnel_conductor(1.0f, material_conductor_eta(m), material_conductor_k(m));
    return 1.0f + material_color(m) * f0 * ((1.0f - e) / e);
}

// f * |cos| of a rough dielectric or conductor lobe, and the density of its sampler.
float3 eval_rough_specular(const Material* m, const SurfacePoint* sp, float3 n, float3 wo, float3 wi) {
    if (material_kind(m) == MATERIAL_DIELECTRIC)
        return eval_dielectric(material_reflection_tint(m), material_color(m), material_eta(m, sp),
                               material_microfacet(m), n, wo, wi);
    return eval_conductor(material_color(m), material_conductor_eta(m), material_conductor_k(m),
                          material_microfacet(m), n, wo, wi);
}

float rough_specular_pdf(const Material* m, const SurfacePoint* sp, float3 n, float3 wo, float3 wi) {
    if (material_kind(m) == MATERIAL_DIELECTRIC)
        return sample_dielectric_pdf(material_eta(m, sp), material_microfacet(m), n, wo, wi);
    return sample_conductor_pdf(material_microfacet(m), n, wo, wi);
}

#endif

// A one-sided material (field one_sided; Mitsuba's BSDFs without `twosided`) seen from
// behind its front face (the side the triangle winding faces) neither reflects nor transmits:
// the path ends there and lights do not reach it.
bool is_one_sided_back(const Material* m, const SurfacePoint* sp) {
    return material_one_sided(m) != 0 && !sp->front_face;
}

bool is_specular_material(const Material* m) {
    int kind = material_kind(m);
    return kind == MATERIAL_DIELECTRIC || kind == MATERIAL_CONDUCTOR || kind == MATERIAL_THIN_DIELECTRIC;
}

bool material_is_delta(const Material* m) {
#if DIELECTRIC
    if (material_kind(m) == MATERIAL_THIN_DIELECTRIC) return true;
    if (is_specular_material(m)) return microfacet_is_smooth(material_alpha(m));
#endif
    return false;
}

INLINE float3 eval_bsdf(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                 float3 wi) {
    if (is_one_sided_back(m, sp)) return (float3)(0.0f);
#if DIELECTRIC
    if (material_kind(m) == MATERIAL_PLASTIC) {
        float3 n = specular_normal(sp, wo);
        if (!sides_agree(dot(wi, sp->ng), dot(wi, n))) return (float3)(0.0f);
        Plastic p = plastic_at(scene, m);
        return eval_plastic(&p, n, wo, wi);
    }
    if (material_kind(m) == MATERIAL_PRINCIPLED) return eval_principled_material(m, sp, specular_normal(sp, wo), wo, wi);
    if (is_specular_material(m)) {
        // A delta lobe has no finite value for a direction chosen elsewhere (light sampling).
        if (material_is_delta(m)) return (float3)(0.0f);
        float3 n = specular_normal(sp, wo);
        if (!sides_agree(dot(wi, sp->ng), dot(wi, n))) return (float3)(0.0f);
        return eval_rough_specular(m, sp, n, wo, wi) * specular_energy_scale(scene, m, sp, dot(n, wo));
    }
#endif
    return eval_diffuse(material_color(m), sp, wi);
}

INLINE float sample_bsdf_pdf(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                             float3 wi) {
    if (is_one_sided_back(m, sp)) return 0.0f;
#if DIELECTRIC
    if (material_kind(m) == MATERIAL_PLASTIC) {
        float3 n = specular_normal(sp, wo);
        if (!sides_agree(dot(wi, sp->ng), dot(wi, n))) return 0.0f;
        Plastic p = plastic_at(scene, m);
        return sample_plastic_pdf(&p, n, wo, wi);
    }
    if (material_kind(m) == MATERIAL_PRINCIPLED)
        return sample_principled_material_pdf(m, sp, specular_normal(sp, wo), wo, wi);
    if (is_specular_material(m)) {
        if (material_is_delta(m)) return 0.0f;
        float3 n = specular_normal(sp, wo);
        if (!sides_agree(dot(wi, sp->ng), dot(wi, n))) return 0.0f;
        return rough_specular_pdf(m, sp, n, wo, wi);
    }
#endif
    return sample_diffuse_pdf(scene, sp, wi);
}

#if DIELECTRIC
// Dielectrics, conductors and thin dielectrics, with the random numbers as arguments (for the
// tests' kernels). Glossy lobes: the weight is eval / pdf of the sampled direction, the same two
// functions that next-event estimation and MIS use, so both strategies agree by construction.
BsdfSample sample_specular_bsdf(const Scene* scene, const Material* m, const SurfacePoint* sp,
                                float3 wo, float rnl, float2 rn) {
    float3 n = specular_normal(sp, wo);
    int kind = material_kind(m);
    if (kind == MATERIAL_THIN_DIELECTRIC)
        return sample_thin_dielectric(material_reflection_tint(m), material_color(m),
                                      material_ior(m) / material_exterior_ior(m), n, sp->ng, wo, rnl);
    bool dielectric = kind == MATERIAL_DIELECTRIC;
    float eta = dielectric ? material_eta(m, sp) : 1.0f;
    if (material_is_delta(m)) {
        if (dielectric)
            return sample_dielectric_delta(material_reflection_tint(m), material_color(m), eta, n, sp->ng, wo, rnl);
        return sample_conductor_delta(material_color(m), material_conductor_eta(m), material_conductor_k(m), n,
                                      sp->ng, wo);
    }
    BsdfSample bs = bsdf_sample_none();
    Microfacet mf = material_microfacet(m);
    float3 wi = dielectric ? sample_dielectric(eta, mf, n, wo, rnl, rn) : sample_conductor(mf, n, wo, rn);
    if (!sides_agree(dot(wi, sp->ng), dot(wi, n))) return bs;  // also rejects the zero vector
    float pdf_w = rough_specular_pdf(m, sp, n, wo, wi);
    if (!(pdf_w > 0.0f)) return bs;
    bs.wi = wi;
    bs.pdf_w = pdf_w;
    bs.weight = eval_rough_specular(m, sp, n, wo, wi) * specular_energy_scale(scene, m, sp, dot(n, wo)) / pdf_w;
    bs.eta = dot(wi, sp->ng) < 0.0f ? eta : 1.0f;
    return bs;
}

// Plastic (materials/plastic.h), with the random numbers as arguments.
BsdfSample sample_plastic_bsdf(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                               float rnl, float2 rn) {
    float3 n = specular_normal(sp, wo);
    Plastic p = plastic_at(scene, m);
    BsdfSample bs = sample_plastic(&p, n, sp->ng, wo, rnl, rn);
    if (!bs.delta && !sides_agree(dot(bs.wi, sp->ng), dot(bs.wi, n))) return bsdf_sample_none();
    return bs;
}
#endif

// Whether sampling the material picks one of several lobes (a dielectric's reflection or
// refraction, plastic's coat or base, the principled model's lobes) with a number of its own.
bool material_picks_lobe(const Material* m) {
#if DIELECTRIC
    return material_kind(m) == MATERIAL_PRINCIPLED || is_specular_material(m) || material_kind(m) == MATERIAL_PLASTIC;
#else
    return false;
#endif
}

// A direction from the material's lobes: rnl picks the lobe (material_picks_lobe), rn places
// the direction in it.
INLINE BsdfSample sample_bsdf_with(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                                   float rnl, float2 rn) {
    if (is_one_sided_back(m, sp)) return bsdf_sample_none();
#if DIELECTRIC
    if (material_kind(m) == MATERIAL_PRINCIPLED) return sample_principled_material(m, sp, specular_normal(sp, wo), wo, rnl, rn);
    if (material_kind(m) == MATERIAL_PLASTIC) return sample_plastic_bsdf(scene, m, sp, wo, rnl, rn);
    if (is_specular_material(m)) return sample_specular_bsdf(scene, m, sp, wo, rnl, rn);
#endif
    BsdfSample bs = bsdf_sample_none();
    bs.wi = sample_diffuse(scene, sp, rn, &bs.pdf_w);
    // For cosine sampling f * cos / pdf is the albedo itself; dividing would only add rounding.
    bs.weight = bs.pdf_w > 0.0f ? material_color(m) : (float3)(0.0f);
    if (scene->params->guide_cells.w != 0 && bs.pdf_w > 0.0f) bs.weight = eval_diffuse(material_color(m), sp, bs.wi) / bs.pdf_w;
    return bs;
}

// sample_bsdf_with drawing its numbers (the light paths, the guide's photons and the direct
// integrator): a lobe's where the material picks one, then the direction's; none from a
// one-sided back.
INLINE BsdfSample sample_bsdf(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                              Rng* rng) {
    if (is_one_sided_back(m, sp)) return bsdf_sample_none();
    float rnl = material_picks_lobe(m) ? rng_float(rng) : 0.0f;
    return sample_bsdf_with(scene, m, sp, wo, rnl, rng_float2(rng));
}

#endif
