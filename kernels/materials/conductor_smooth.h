// The smooth conductor (a metal mirror): the complex Fresnel reflectance and its delta lobe,
// written over the lane types (lanes.h). Conventions: conductor.h.
#ifndef CLRENDER_CONDUCTOR_SMOOTH_H
#define CLRENDER_CONDUCTOR_SMOOTH_H
#include "lanes.h"
#include "math.h"
#include "materials/bsdf_sample.h"
#include "materials/dielectric_smooth.h"
#if DIELECTRIC

// One channel of fresnel_conductor, from cos_i and its square c2, s2 = 1 - c2 and s4 = s2^2.
lane_float fresnel_conductor_channel(lane_float cos_i, lane_float c2, lane_float s2, lane_float s4, lane_float eta,
                                     lane_float k) {
    lane_float t = eta * eta - k * k - s2;
    lane_float a2_b2 = sqrt(fmax(t * t + 4.0f * k * k * eta * eta, 0.0f));
    lane_float a = sqrt(fmax(0.5f * (a2_b2 + t), 0.0f));
    lane_float t1 = a2_b2 + c2, t2 = 2.0f * cos_i * a;
    lane_float r_s = (t1 - t2) / (t1 + t2);
    lane_float t3 = a2_b2 * c2 + s4, t4 = t2 * s2;
    lane_float r_p = r_s * (t3 - t4) / (t3 + t4);
    return select(0.5f * (r_s + r_p), (lane_float)(1.0f), (eta == 0.0f) & (k == 0.0f));
}

// Unpolarised Fresnel reflectance of a conductor, per channel, at cos_i in [0, 1] (Mitsuba 3's
// fresnel_conductor, after K. D. Moeller, "Optics", 1988; exact, with a^2 + b^2 = |eta^2 - sin^2|).
// eta = k = 0 reflects everything; said outright, since the formula divides 0 by 0 at normal
// incidence there.
lane_float3 fresnel_conductor(lane_float cos_i, lane_float3 eta, lane_float3 k) {
    lane_float c2 = cos_i * cos_i, s2 = 1.0f - c2, s4 = s2 * s2;
    return make_lane_float3(fresnel_conductor_channel(cos_i, c2, s2, s4, eta.x, k.x),
                            fresnel_conductor_channel(cos_i, c2, s2, s4, eta.y, k.y),
                            fresnel_conductor_channel(cos_i, c2, s2, s4, eta.z, k.z));
}

// ng: the geometric normal on wo's side. An interpolated normal can mirror wo into the surface
// near silhouettes; the facet's own mirror direction is used then, which keeps the energy.
BsdfSample sample_conductor_delta(lane_float3 tint, lane_float3 eta, lane_float3 k, lane_float3 n, lane_float3 ng,
                                  lane_float3 wo) {
    BsdfSample bs = bsdf_sample_none();
    bs.delta = LANE_TRUE;
    lane_float3 wi = reflect(wo, n);
    lane_int below = l3_dot(wi, ng) <= 0.0f;
    lane_float3 mirror = l3_select(n, ng, below);
    if (lane_any(below)) wi = l3_select(wi, reflect(wo, ng), below);
    bs.wi = wi;
    bs.weight = l3_mul(tint, fresnel_conductor(clamp(l3_dot(wo, mirror), 0.0f, 1.0f), eta, k));
    bs.pdf_w = 1.0f;
    return bs;
}

#endif
#endif
