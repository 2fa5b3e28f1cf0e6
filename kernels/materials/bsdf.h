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
#include "materials/energy.h"
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
    return dielectric ? (float3)(1.0f / e) : 1.0f + material_color(m) * ((1.0f - e) / e);
}

// A glossy lobe counts only where the geometric and the shading normal put wi on the same side,
// as eval_diffuse does; otherwise light would leak through the facet.
bool sides_agree(float a, float b) { return (a > 0.0f && b > 0.0f) || (a < 0.0f && b < 0.0f); }
#endif

// A one-sided material (field one_sided; Mitsuba's BSDFs without `twosided`) seen from
// behind its front face (the side the triangle winding faces) neither reflects nor transmits:
// the path ends there and lights do not reach it.
bool is_one_sided_back(const Material* m, const SurfacePoint* sp) {
    return material_one_sided(m) != 0 && !sp->front_face;
}

bool is_specular_material(const Material* m) {
    return material_kind(m) == MATERIAL_DIELECTRIC || material_kind(m) == MATERIAL_CONDUCTOR;
}

bool material_is_delta(const Material* m) {
#if DIELECTRIC
    if (is_specular_material(m)) return microfacet_is_smooth(material_alpha(m));
#endif
    return false;
}

INLINE float3 eval_bsdf(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                 float3 wi) {
    if (is_one_sided_back(m, sp)) return (float3)(0.0f);
#if DIELECTRIC
    if (material_kind(m) == MATERIAL_PRINCIPLED) return eval_principled_material(m, sp, specular_normal(sp, wo), wo, wi);
    if (is_specular_material(m)) {
        // A delta lobe has no finite value for a direction chosen elsewhere (light sampling).
        if (material_is_delta(m)) return (float3)(0.0f);
        float3 n = specular_normal(sp, wo);
        if (!sides_agree(dot(wi, sp->ng), dot(wi, n))) return (float3)(0.0f);
        float3 f = material_kind(m) == MATERIAL_DIELECTRIC
            ? eval_dielectric(material_color(m), material_eta(m, sp), material_alpha(m), n, wo, wi)
            : eval_conductor(material_color(m), material_alpha(m), n, wo, wi);
        return f * specular_energy_scale(scene, m, sp, dot(n, wo));
    }
#endif
    return eval_diffuse(material_color(m), sp, wi);
}

INLINE float sample_bsdf_pdf(const Material* m, const SurfacePoint* sp, float3 wo, float3 wi) {
    if (is_one_sided_back(m, sp)) return 0.0f;
#if DIELECTRIC
    if (material_kind(m) == MATERIAL_PRINCIPLED)
        return sample_principled_material_pdf(m, sp, specular_normal(sp, wo), wo, wi);
    if (is_specular_material(m)) {
        if (material_is_delta(m)) return 0.0f;
        float3 n = specular_normal(sp, wo);
        if (!sides_agree(dot(wi, sp->ng), dot(wi, n))) return 0.0f;
        if (material_kind(m) == MATERIAL_DIELECTRIC)
            return sample_dielectric_pdf(material_eta(m, sp), material_alpha(m), n, wo, wi);
        return sample_conductor_pdf(material_alpha(m), n, wo, wi);
    }
#endif
    return sample_diffuse_pdf(sp, wi);
}

#if DIELECTRIC
// Dielectrics and conductors, with the random numbers as arguments (for the tests' kernels).
// Glossy lobes: the weight is eval / pdf of the sampled direction, the same two functions that
// next-event estimation and MIS use, so both strategies agree by construction.
BsdfSample sample_specular_bsdf(const Scene* scene, const Material* m, const SurfacePoint* sp,
                                float3 wo, float rnl, float2 rn) {
    float3 n = specular_normal(sp, wo);
    float alpha = material_alpha(m);
    bool dielectric = material_kind(m) == MATERIAL_DIELECTRIC;
    float eta = dielectric ? material_eta(m, sp) : 1.0f;
    if (material_is_delta(m)) {
        if (!dielectric) return sample_conductor_delta(material_color(m), n, sp->ng, wo);
        return sample_dielectric_delta(material_color(m), eta, n, sp->ng, wo, rnl);
    }
    BsdfSample bs = bsdf_sample_none();
    float3 wi = dielectric ? sample_dielectric(eta, alpha, n, wo, rnl, rn) : sample_conductor(alpha, n, wo, rn);
    if (!sides_agree(dot(wi, sp->ng), dot(wi, n))) return bs;  // also rejects the zero vector
    float pdf_w = dielectric ? sample_dielectric_pdf(eta, alpha, n, wo, wi) : sample_conductor_pdf(alpha, n, wo, wi);
    if (!(pdf_w > 0.0f)) return bs;
    float3 f = dielectric ? eval_dielectric(material_color(m), eta, alpha, n, wo, wi)
                          : eval_conductor(material_color(m), alpha, n, wo, wi);
    bs.wi = wi;
    bs.pdf_w = pdf_w;
    bs.weight = f * specular_energy_scale(scene, m, sp, dot(n, wo)) / pdf_w;
    bs.eta = dot(wi, sp->ng) < 0.0f ? eta : 1.0f;
    return bs;
}
#endif

INLINE BsdfSample sample_bsdf(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                       Rng* rng) {
    if (is_one_sided_back(m, sp)) return bsdf_sample_none();
#if DIELECTRIC
    bool principled = material_kind(m) == MATERIAL_PRINCIPLED;
    if (principled || is_specular_material(m)) {
        float rnl = rng_float(rng);
        float2 rn = rng_float2(rng);
        if (principled) return sample_principled_material(m, sp, specular_normal(sp, wo), wo, rnl, rn);
        return sample_specular_bsdf(scene, m, sp, wo, rnl, rn);
    }
#endif
    BsdfSample bs = bsdf_sample_none();
    bs.wi = sample_diffuse(sp, rng_float2(rng));
    bs.pdf_w = sample_diffuse_pdf(sp, bs.wi);
    // For cosine sampling f * cos / pdf is the albedo itself; dividing would only add rounding.
    bs.weight = bs.pdf_w > 0.0f ? material_color(m) : (float3)(0.0f);
    return bs;
}

#endif
