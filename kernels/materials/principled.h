// Mitsuba 3.9's `principled` BSDF (its principled.cpp and principledhelpers.h; Burley's Disney
// BSDF as Mitsuba writes it), lobe for lobe, with Mitsuba's lobe-sampling probabilities and pdf:
//   diffuse: Burley's diffuse with retro-reflection, blended towards the Hanrahan-Krueger-like
//     "fake subsurface" by `flatness`; sheen; both weighted by (1 - metallic)(1 - spec_trans)
//     (sheen by (1 - metallic), present only where that weight is non-zero, as Mitsuba's scalar
//     variants evaluate it);
//   main specular: anisotropic GGX with Smith's separable masking, reflection with a Fresnel
//     term that mixes the dielectric's, a Schlick metallic one tinted by base_color and a Schlick
//     one tinted by spec_tint; transmission (spec_trans) tinted by sqrt(base_color);
//   clearcoat: GTR1 with alpha = lerp(0.1, 0.001, clearcoat_gloss), Schlick's Fresnel from 0.04,
//     separable GGX masking with alpha 0.25, weighted clearcoat / 4 and (as Mitsuba writes it)
//     without the 1 / (4 cos cos) of a microfacet lobe.
// Seen from inside (the back of the front face) only the specular lobes remain, reflection and
// transmission with the dielectric's Fresnel term, weighted (1 - metallic) spec_trans: without
// transmission the back is black.
//
// The pure functions work in Mitsuba's local shading frame (s, t, n: x, y, z), with n the
// object's outward shading normal, so wo.z < 0 means wo is inside. Directions point away from
// the surface: wo towards the viewer (Mitsuba's si.wi), wi towards the light (Mitsuba's wo).
// eval_principled returns f * |cos(wi)| with the 1 / eta^2 of radiance transport, as Mitsuba's
// eval in radiance mode does; sample_principled draws the mixture that
// sample_principled_pdf (Mitsuba's pdf) describes, exactly.
#ifndef CLRENDER_PRINCIPLED_H
#define CLRENDER_PRINCIPLED_H
#include "math.h"
#include "sampling.h"
#include "scene.h"
#include "materials/bsdf_sample.h"
#include "materials/material.h"
#include "materials/dielectric_smooth.h"
#if DIELECTRIC

typedef struct {
    float3 base_color;
    float roughness, anisotropic, metallic, spec_trans, spec_tint, sheen, sheen_tint, clearcoat,
          clearcoat_gloss, flatness;
    float eta;                                             // interior / exterior index
    float specular_rate, clearcoat_rate, diffuse_rate;     // Mitsuba's *_sampling_rate
} Principled;

Principled principled_params(const Material* m) {
    Principled p;
    p.base_color = material_color(m);
    p.roughness = material_principled_roughness(m);
    p.anisotropic = material_principled_anisotropic(m);
    p.metallic = material_principled_metallic(m);
    p.spec_trans = material_principled_spec_trans(m);
    p.spec_tint = material_principled_spec_tint(m);
    p.sheen = material_principled_sheen(m);
    p.sheen_tint = material_principled_sheen_tint(m);
    p.clearcoat = material_principled_clearcoat(m);
    p.clearcoat_gloss = material_principled_clearcoat_gloss(m);
    p.flatness = material_principled_flatness(m);
    p.eta = material_principled_eta(m);
    p.specular_rate = material_principled_specular_rate(m);
    p.clearcoat_rate = material_principled_clearcoat_rate(m);
    p.diffuse_rate = material_principled_diffuse_rate(m);
    return p;
}

// ----- Mitsuba's building blocks -------------------------------------------------------------------
float principled_diffuse_weight(const Principled* p) { return (1.0f - p->metallic) * (1.0f - p->spec_trans); }
float principled_transmission_weight(const Principled* p) { return (1.0f - p->metallic) * p->spec_trans; }

// (1 - cos)^5, cos clamped to [0, 1].
float schlick_weight(float cos_theta) {
    float m = clamp(1.0f - cos_theta, 0.0f, 1.0f);
    float m2 = m * m;
    return m2 * m2 * m;
}

// Mitsuba's fresnel(cos, eta): cos < 0 is incidence from inside (the index inverted).
float principled_fresnel_dielectric(float cos_theta, float eta) {
    return fresnel_dielectric(fabs(cos_theta), cos_theta >= 0.0f ? eta : 1.0f / eta);
}

// The weight Mitsuba's Schlick terms lerp with (calc_schlick): of the incident angle where the
// light goes into the denser side, else of the transmitted angle (1 beyond the critical angle).
float principled_schlick_weight(float cos_theta, float eta) {
    float eta_it = cos_theta >= 0.0f ? eta : 1.0f / eta;
    if (eta_it > 1.0f) return schlick_weight(fabs(cos_theta));
    float cos_t2 = 1.0f - (1.0f - cos_theta * cos_theta) / (eta_it * eta_it);
    return schlick_weight(sqrt(fmax(cos_t2, 0.0f)));
}

// base / luminance(base): the hue that spec_tint and sheen_tint tint towards (white for black).
float3 principled_tint(float3 base_color) {
    float lum = luminance(base_color);
    return lum > 0.0f ? base_color / lum : (float3)(1.0f);
}

// GGX widths (alpha_u, alpha_v) from roughness and anisotropic (calc_dist_params).
float2 principled_alphas(const Principled* p) {
    float r2 = p->roughness * p->roughness;
    float aspect = sqrt(1.0f - 0.9f * p->anisotropic);
    return fmax((float2)(0.001f), (float2)(r2 / aspect, r2 * aspect));
}

// Anisotropic GGX D(m) in the local frame (Mitsuba's MicrofacetDistribution::eval).
float aniso_ggx_d(float3 m, float2 alpha) {
    float x = m.x / alpha.x, y = m.y / alpha.y;
    float k = x * x + y * y + m.z * m.z;
    float d = 1.0f / (PI_F * alpha.x * alpha.y * k * k);
    return d * m.z > 1e-20f ? d : 0.0f;
}

// Smith's masking of direction v by microfacet m; 0 where v sees m's back.
float aniso_ggx_g1(float3 v, float3 m, float2 alpha) {
    if (dot(v, m) * v.z <= 0.0f) return 0.0f;
    float xy = alpha.x * alpha.x * v.x * v.x + alpha.y * alpha.y * v.y * v.y;
    if (xy == 0.0f) return 1.0f;
    return 2.0f / (1.0f + sqrt(1.0f + xy / (v.z * v.z)));
}

// Visible-normal density of m seen from v (v.z > 0).
float aniso_ggx_vndf_pdf(float3 v, float3 m, float2 alpha) {
    return aniso_ggx_d(m, alpha) * aniso_ggx_g1(v, m, alpha) * fabs(dot(v, m)) / v.z;
}

// A visible normal for v (v.z > 0), distributed as aniso_ggx_vndf_pdf: Dupuy and Benyoub 2023,
// "Sampling Visible GGX Normals with Spherical Caps": in the unit-roughness configuration the
// visible normal is v plus a point of the spherical cap z >= -v.z of the unit sphere.
float3 sample_aniso_ggx_vndf(float3 v, float2 alpha, float2 u) {
    float3 vs = normalize((float3)(alpha.x * v.x, alpha.y * v.y, v.z));
    float z = (1.0f - u.x) * (1.0f + vs.z) - vs.z;
    float r = sqrt(clamp(1.0f - z * z, 0.0f, 1.0f));
    float s_phi, c_phi;
    sincos_2pi(u.y, &s_phi, &c_phi);
    float3 h = vs + (float3)(r * c_phi, r * s_phi, z);
    return normalize((float3)(alpha.x * h.x, alpha.y * h.y, fmax(h.z, 0.0f)));
}

// GTR1 ("Berry") distribution of the clearcoat: D(m) and its sampling by cos-weighted density.
float clearcoat_alpha(const Principled* p) { return 0.1f + (0.001f - 0.1f) * p->clearcoat_gloss; }

float gtr1_d(float3 m, float alpha) {
    float a2 = alpha * alpha;
    float d = (a2 - 1.0f) / (PI_F * log(a2) * (1.0f + (a2 - 1.0f) * m.z * m.z));
    return d * m.z > 1e-20f ? d : 0.0f;
}

float3 sample_gtr1(float alpha, float2 u) {
    float a2 = alpha * alpha;
    float cos2 = (1.0f - exp2((1.0f - u.y) * log2(a2))) / (1.0f - a2);
    float s_phi, c_phi;
    sincos_2pi(u.x, &s_phi, &c_phi);
    float sin_theta = sqrt(fmax(0.0f, 1.0f - cos2));
    return (float3)(c_phi * sin_theta, s_phi * sin_theta, sqrt(fmax(0.0f, cos2)));
}

// Isotropic GGX masking with alpha 0.25 (Mitsuba's clearcoat_G is a product of two of these).
float clearcoat_g1(float3 v, float3 m) {
    if (dot(v, m) * v.z <= 0.0f) return 0.0f;
    float c2 = v.z * v.z;
    if (c2 >= 1.0f) return 1.0f;
    return 2.0f / (1.0f + sqrt(1.0f + 0.0625f * (1.0f - c2) / c2));
}

// The generalised half vector of (wo, wi), facing out of the object (z >= 0), and whether the
// pair reflects; zero where it has none (transmission straight through at eta 1).
float3 principled_half_vector(const Principled* p, float3 wo, float3 wi) {
    bool reflect = wo.z * wi.z > 0.0f;
    float eta_path = wo.z > 0.0f ? p->eta : 1.0f / p->eta;
    float3 h = reflect ? wo + wi : wo + wi * eta_path;
    float len2 = dot(h, h);
    if (!(len2 > 0.0f)) return (float3)(0.0f);
    h *= rsqrt(len2);
    return h.z < 0.0f ? -h : h;
}

// Reflectance of the main specular lobe at microfacet cosine cos_oh (principled_fresnel): from
// outside a mix of the dielectric, the metallic and the spec_tint terms; from inside the
// dielectric's, weighted by the transmission weight.
float3 principled_specular_fresnel(const Principled* p, float f_dielectric, float cos_oh, bool front) {
    if (!front) return (float3)(principled_transmission_weight(p) * f_dielectric);
    float w = principled_schlick_weight(cos_oh, p->eta);
    float eta_it = cos_oh >= 0.0f ? p->eta : 1.0f / p->eta;
    float r0 = (eta_it - 1.0f) / (eta_it + 1.0f);
    float3 tinted_r0 = principled_tint(p->base_color) * (r0 * r0);
    float3 metal = p->base_color + (1.0f - p->base_color) * w;
    float3 tinted = tinted_r0 + (1.0f - tinted_r0) * w;
    return (1.0f - p->metallic) * (1.0f - p->spec_tint) * f_dielectric + p->metallic * metal +
           (1.0f - p->metallic) * p->spec_tint * tinted;
}

// Diffuse (retro-reflection, fake subsurface) and sheen, f * cos_i, both directions outside.
float3 principled_diffuse_and_sheen(const Principled* p, float3 wo, float3 wi, float3 h) {
    float weight = principled_diffuse_weight(p);
    if (!(weight > 0.0f)) return (float3)(0.0f);
    float f_o = schlick_weight(wo.z), f_i = schlick_weight(wi.z);
    float cos_d = dot(h, wi);
    float f_diffuse = (1.0f - 0.5f * f_o) * (1.0f - 0.5f * f_i);
    float rr = 2.0f * p->roughness * cos_d * cos_d;
    float f_retro = rr * (f_o + f_i + f_o * f_i * (rr - 1.0f));
    float fss90 = cos_d * cos_d * p->roughness;
    float fss = (1.0f + (fss90 - 1.0f) * f_o) * (1.0f + (fss90 - 1.0f) * f_i);
    float f_ss = 1.25f * (fss * (1.0f / (wo.z + wi.z) - 0.5f) + 0.5f);
    float f = (f_diffuse + f_retro) + (f_ss - (f_diffuse + f_retro)) * p->flatness;
    float3 value = p->base_color * (weight * wi.z * INV_PI_F * f);
    if (p->sheen > 0.0f && p->metallic < 1.0f) {
        float3 tint = 1.0f + (principled_tint(p->base_color) - 1.0f) * p->sheen_tint;
        value += tint * (p->sheen * (1.0f - p->metallic) * schlick_weight(fabs(cos_d)) * wi.z);
    }
    return value;
}

// ----- eval, pdf, sample ---------------------------------------------------------------------------
float3 eval_principled(const Principled* p, float3 wo, float3 wi) {
    bool front = wo.z > 0.0f;
    bool reflect = wo.z * wi.z > 0.0f, refract = wo.z * wi.z < 0.0f;
    float transmission = principled_transmission_weight(p);
    if (wo.z == 0.0f || (!front && !(transmission > 0.0f))) return (float3)(0.0f);
    float3 h = principled_half_vector(p, wo, wi);
    if (h.z == 0.0f) return (float3)(0.0f);
    float2 alpha = principled_alphas(p);
    float cos_oh = dot(wo, h), cos_ih = dot(wi, h);
    float f = principled_fresnel_dielectric(cos_oh, p->eta);
    float dg = aniso_ggx_d(h, alpha) * aniso_ggx_g1(wo, h, alpha) * aniso_ggx_g1(wi, h, alpha);
    float3 value = (float3)(0.0f);
    if (reflect) value = principled_specular_fresnel(p, f, cos_oh, front) * (dg / (4.0f * fabs(wo.z)));
    if (refract && transmission > 0.0f) {
        // Mitsuba's eta_path^2 and the radiance's 1 / eta_path^2 cancel.
        float eta_path = front ? p->eta : 1.0f / p->eta;
        float denominator = cos_oh + eta_path * cos_ih;
        value = sqrt(p->base_color) *
                (transmission * fabs((1.0f - f) * dg * cos_oh * cos_ih / (wo.z * denominator * denominator)));
    }
    if (reflect && front) {
        if (p->clearcoat > 0.0f) {
            float fresnel = 0.04f + 0.96f * principled_schlick_weight(cos_oh, p->eta);
            float g = clearcoat_g1(wo, h) * clearcoat_g1(wi, h);
            value += (float3)(0.25f * p->clearcoat * fresnel * gtr1_d(h, clearcoat_alpha(p)) * g * wi.z);
        }
        value += principled_diffuse_and_sheen(p, wo, wi, h);
    }
    return value;
}

// Probabilities of the lobes from outside, unnormalised: (specular, clearcoat, diffuse). The
// specular share then splits into reflection and transmission at the microfacet's Fresnel term
// (prob_spec_reflect + prob_spec_trans in Mitsuba, whose sum does not depend on it).
float3 principled_lobe_rates(const Principled* p) {
    return (float3)(p->specular_rate, 0.25f * p->clearcoat * p->clearcoat_rate,
                    principled_diffuse_weight(p) * p->diffuse_rate);
}

// The probability that the specular lobe transmits at a microfacet of dielectric reflectance f.
float principled_transmit_probability(const Principled* p, float f, bool front) {
    return front ? principled_transmission_weight(p) * (1.0f - f) : 1.0f - f;
}

float sample_principled_pdf(const Principled* p, float3 wo, float3 wi) {
    bool front = wo.z > 0.0f;
    bool reflect = wo.z * wi.z > 0.0f, refract = wo.z * wi.z < 0.0f;
    if (wo.z == 0.0f || (!front && !(principled_transmission_weight(p) > 0.0f))) return 0.0f;
    float3 h = principled_half_vector(p, wo, wi);
    if (h.z == 0.0f || !(reflect || refract)) return 0.0f;
    float3 rates = front ? principled_lobe_rates(p) : (float3)(1.0f, 0.0f, 0.0f);
    float total = rates.x + rates.y + rates.z;
    float cos_oh = dot(wo, h), cos_ih = dot(wi, h);
    float eta_path = front ? p->eta : 1.0f / p->eta;
    float denominator = cos_oh + eta_path * cos_ih;
    float jacobian = reflect ? 1.0f / (4.0f * fabs(cos_ih))
                             : fabs(eta_path * eta_path * cos_ih / (denominator * denominator));
    // The microfacet must face wo, and wi must leave it on the side its lobe sends light.
    float3 hs = front ? h : -h;
    float pdf = 0.0f;
    if (dot(wo, hs) > 0.0f && (reflect ? dot(wi, hs) > 0.0f : dot(wi, hs) < 0.0f)) {
        float transmit = principled_transmit_probability(p, principled_fresnel_dielectric(cos_oh, p->eta), front);
        float3 v = front ? wo : -wo;
        pdf = rates.x * (reflect ? 1.0f - transmit : transmit) * aniso_ggx_vndf_pdf(v, h, principled_alphas(p)) * jacobian;
    }
    if (reflect && front)
        pdf += rates.y * gtr1_d(h, clearcoat_alpha(p)) * h.z * jacobian + rates.z * wi.z * INV_PI_F;
    return pdf / total;
}

// wi for wo, or the zero vector for no sample. rnl picks the lobe (and, rescaled, reflection or
// transmission), rn the direction.
float3 sample_principled(const Principled* p, float3 wo, float rnl, float2 rn) {
    bool front = wo.z > 0.0f;
    if (wo.z == 0.0f || (!front && !(principled_transmission_weight(p) > 0.0f))) return (float3)(0.0f);
    float3 rates = front ? principled_lobe_rates(p) : (float3)(1.0f, 0.0f, 0.0f);
    float u = rnl * (rates.x + rates.y + rates.z);
    float3 wi;
    if (u < rates.z) {
        wi = sample_cosine_hemisphere(rn);
    } else if (u < rates.z + rates.y) {
        wi = reflect(wo, sample_gtr1(clearcoat_alpha(p), rn));
    } else {
        float3 v = front ? wo : -wo;
        float3 m = sample_aniso_ggx_vndf(v, principled_alphas(p), rn);
        float cos_om = dot(wo, m);
        float transmit = principled_transmit_probability(p, principled_fresnel_dielectric(cos_om, p->eta), front);
        if ((u - rates.z - rates.y) >= rates.x * (1.0f - transmit)) {
            if (!refract(wo, front ? m : -m, front ? p->eta : 1.0f / p->eta, &wi)) return (float3)(0.0f);
            return wi.z * wo.z < 0.0f ? wi : (float3)(0.0f);
        }
        wi = reflect(wo, m);
    }
    return wi.z * wo.z > 0.0f ? wi : (float3)(0.0f);
}

// ----- on a surface point ------------------------------------------------------------------------
// Mitsuba's shading frame: n the shading normal on the front side (n_wo: the normal the
// specular materials use, on wo's side, bsdf.h specular_normal), s along dp/du projected onto
// the tangent plane, t = n x s. Without uv (TEXTURES off: only isotropic materials) or where
// dp/du is parallel to n, any tangent will do.
typedef struct {
    float3 s, t, n;
} ShadingFrame;

ShadingFrame principled_frame(const SurfacePoint* sp, float3 n_wo) {
    ShadingFrame f;
    f.n = sp->front_face ? n_wo : -n_wo;
    make_basis(f.n, &f.s, &f.t);
#if TEXTURES
    float3 s = sp->dpdu - f.n * dot(f.n, sp->dpdu);
    float len2 = dot(s, s);
    if (len2 > 0.0f) {
        f.s = s * rsqrt(len2);
        f.t = cross(f.n, f.s);
    }
#endif
    return f;
}

float3 to_frame(const ShadingFrame* f, float3 v) { return (float3)(dot(v, f->s), dot(v, f->t), dot(v, f->n)); }
float3 from_frame(const ShadingFrame* f, float3 v) { return v.x * f->s + v.y * f->t + v.z * f->n; }

// A direction counts only where the facet and the shading normal put it on the same side, as
// for the other glossy lobes (microfacet.h sides_agree): otherwise light would leak through the facet.
bool principled_sides_agree(const SurfacePoint* sp, float3 n_wo, float3 wi) {
    return dot(wi, sp->ng) * dot(wi, n_wo) > 0.0f;
}

float3 eval_principled_material(const Material* m, const SurfacePoint* sp, float3 n_wo, float3 wo, float3 wi) {
    if (!principled_sides_agree(sp, n_wo, wi)) return (float3)(0.0f);
    Principled p = principled_params(m);
    ShadingFrame f = principled_frame(sp, n_wo);
    return eval_principled(&p, to_frame(&f, wo), to_frame(&f, wi));
}

float sample_principled_material_pdf(const Material* m, const SurfacePoint* sp, float3 n_wo, float3 wo, float3 wi) {
    if (!principled_sides_agree(sp, n_wo, wi)) return 0.0f;
    Principled p = principled_params(m);
    ShadingFrame f = principled_frame(sp, n_wo);
    return sample_principled_pdf(&p, to_frame(&f, wo), to_frame(&f, wi));
}

// Weight eval / pdf of the sampled direction (the two functions next-event estimation and MIS
// use, so both strategies agree by construction).
BsdfSample sample_principled_material(const Material* m, const SurfacePoint* sp, float3 n_wo, float3 wo,
                                      float rnl, float2 rn) {
    BsdfSample bs = bsdf_sample_none();
    Principled p = principled_params(m);
    ShadingFrame f = principled_frame(sp, n_wo);
    float3 wo_local = to_frame(&f, wo);
    float3 wi_local = sample_principled(&p, wo_local, rnl, rn);
    float3 wi = from_frame(&f, wi_local);
    if (wi_local.z == 0.0f || !principled_sides_agree(sp, n_wo, wi)) return bs;
    float pdf_w = sample_principled_pdf(&p, wo_local, wi_local);
    if (!(pdf_w > 0.0f)) return bs;
    bs.wi = wi;
    bs.pdf_w = pdf_w;
    bs.weight = eval_principled(&p, wo_local, wi_local) / pdf_w;
    bool crossed = wi_local.z * wo_local.z < 0.0f;
    bs.eta = !crossed ? 1.0f : (wo_local.z > 0.0f ? p.eta : 1.0f / p.eta);
    return bs;
}

#endif
#endif
