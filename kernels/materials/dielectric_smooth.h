// The smooth dielectric interface: Fresnel reflectance, Snell refraction and the pair of delta
// lobes, written over the lane types (lanes.h). Conventions and transport: dielectric.h.
#ifndef CLRENDER_DIELECTRIC_SMOOTH_H
#define CLRENDER_DIELECTRIC_SMOOTH_H
#include "lanes.h"
#include "math.h"
#include "materials/bsdf_sample.h"
#if DIELECTRIC

// cos of the transmitted angle, from Snell's law written as cos_t^2 = (eta^2 - 1 + cos_i^2) / eta^2
// rather than 1 - sin_t^2: near grazing 1 - (1 - cos_i^2) cancels to a few ulps, and at eta = 1
// this form gives cos_t = cos_i (exactly where sqrt rounds correctly). Negative: total internal
// reflection.
lane_float cos_transmitted(lane_float cos_i, lane_float eta) {
    lane_float g2 = eta * eta - 1.0f + cos_i * cos_i;
    return select((lane_float)(-1.0f), sqrt(g2) / eta, g2 > 0.0f);
}

// Unpolarised Fresnel reflectance of a dielectric interface, cos_i in [0, 1] on the incident
// side (Born and Wolf; pbrt-v4 FrDielectric), exact, not Schlick's approximation. Past the
// critical angle it is exactly 1 (total internal reflection). Both denominators are > 0 where
// there is a transmitted ray, since then cos_t > 0.
lane_float fresnel_dielectric(lane_float cos_i, lane_float eta) {
    cos_i = clamp(cos_i, 0.0f, 1.0f);
    lane_float cos_t = cos_transmitted(cos_i, eta);
    lane_float r_parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    lane_float r_perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    lane_float f = 0.5f * (r_parallel * r_parallel + r_perpendicular * r_perpendicular);
    // No interface reflects nothing and grazing incidence everything; said outright, because the
    // formula gets there only where sqrt(c * c) = c and x / x = 1, i.e. with correctly rounded
    // division and square roots, which GPUs do not give by default (OpenCL allows 2.5 and 3 ulp).
    f = select(f, (lane_float)(1.0f), (cos_t <= 0.0f) | (cos_i == 0.0f));
    return select(f, (lane_float)(0.0f), eta == 1.0f);
}

lane_float3 reflect(lane_float3 wo, lane_float3 n) {
    return l3_normalize(l3_sub(l3_scale(n, 2.0f * l3_dot(wo, n)), wo));
}

// Snell's law: the transmitted direction for wo on n's side, false (and *wt unchanged) under
// total internal reflection.
lane_int refract(lane_float3 wo, lane_float3 n, lane_float eta, lane_float3* wt) {
    lane_float cos_i = clamp(l3_dot(n, wo), 0.0f, 1.0f);
    lane_float cos_t = cos_transmitted(cos_i, eta);
    lane_int refracts = cos_t > 0.0f;
    if (lane_any(refracts))
        *wt = l3_select(*wt, l3_normalize(l3_madd(n, cos_i / eta - cos_t, l3_div(l3_neg(wo), eta))), refracts);
    return refracts;
}

// ----- smooth interface: two delta lobes, picked with probability F and 1 - F ------------------
// The weight of the chosen lobe is its throughput divided by its probability: reflect_tint for
// reflection (Mitsuba's specular_reflectance, usually 1), tint / eta^2 for refraction. eta == 1 is an index-matched interface: the ray goes straight on,
// so the object vanishes exactly, with no Fresnel term rounded to a tiny non-zero value.
// n may be an interpolated normal and ng is the facet's, both on wo's side. Near silhouettes n
// can send the reflected ray into the object or the refracted one back out; such a ray would
// cross (or not cross) the interface against its eta^2 scaling, or enter the glass at an angle
// that total internal reflection then traps forever. The facet's normal decides the direction
// then; if refraction about it is impossible, the ray reflects (energy kept).
BsdfSample sample_dielectric_delta(lane_float3 reflect_tint, lane_float3 tint, lane_float eta, lane_float3 n,
                                  lane_float3 ng, lane_float3 wo, lane_float rnl) {
    BsdfSample bs = bsdf_sample_none();
    bs.delta = LANE_TRUE;
    lane_float f = fresnel_dielectric(l3_dot(n, wo), eta);
    lane_int reflected = rnl < f;
    bs.pdf_w = select(1.0f - f, f, reflected);
    // f < 1 where not reflected, so refraction about n exists; about ng it may not.
    lane_float3 wt = bs.wi;
    lane_int refracts = refract(wo, n, eta, &wt);
    lane_int wrong_side = (!reflected) & refracts & (l3_dot(wt, ng) >= 0.0f);
    if (lane_any(wrong_side)) {
        // Into a vector of its own: refract writes every lane that refracts about ng, and the
        // other lanes' directions must not depend on their packet.
        lane_float3 wt_ng = wt;
        refracts = select(refracts, refract(wo, ng, eta, &wt_ng), wrong_side);
        wt = l3_select(wt, wt_ng, wrong_side);
    }
    reflected = reflected | !refracts;
    lane_float3 wr = reflect(wo, n);
    lane_int below = l3_dot(wr, ng) <= 0.0f;
    if (lane_any(reflected & below)) wr = l3_select(wr, reflect(wo, ng), below);
    bs.wi = l3_select(wt, wr, reflected);
    bs.weight = l3_select(l3_div(tint, eta * eta), reflect_tint, reflected);
    bs.eta = select(eta, (lane_float)(1.0f), reflected);
    lane_int matched = eta == 1.0f;
    bs.wi = l3_select(bs.wi, l3_neg(wo), matched);
    bs.weight = l3_select(bs.weight, tint, matched);
    bs.pdf_w = select(bs.pdf_w, (lane_float)(1.0f), matched);
    bs.eta = select(bs.eta, (lane_float)(1.0f), matched);
    return bs;
}

#endif
#endif
