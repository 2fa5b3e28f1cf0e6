// Henyey-Greenstein phase function. cos_theta is the scattering angle: the cosine between the
// direction the light travelled before scattering and after (forward scattering: cos_theta = 1).
//
// As |g| -> 1 the lobe narrows to angles ~ (1 - |g|), so 1 - |cos_theta| falls far below the
// float spacing near 1 (6e-8): computing cos_theta first and then sin_theta = sqrt(1 - cos^2)
// quantises the angle to >= 3.5e-4 rad and visibly distorts the distribution at g = 0.999.
// Everything below works with t = 1 - |cos_theta| measured from the lobe's peak instead, which
// keeps full relative precision.
#ifndef CLRENDER_PHASE_H
#define CLRENDER_PHASE_H
#include "math.h"

// Below this |g| the isotropic phase is used instead (within O(g) of HG), in both sampling
// and evaluation so they stay consistent; the inverse CDF divides by g.
#define HG_ISOTROPIC_G 1e-3f
// |g| = 1 (e.g. g = 0.99999999, which rounds to 1 in float32) is a delta lobe, whose density is
// 0 / 0 at the peak. The largest float below 1 keeps every term finite: 1 - g = 6e-8 exactly,
// a peak density of 5e13.
#define HG_MAX_G 0.99999994f

// HG for g >= 0 at t = 1 - cos_theta: 1 + g^2 - 2 g cos_theta = (1 - g)^2 + 2 g t, without
// the cancellation of the usual form near the peak.
float hg_density(float t, float g) {
    float denom = (1.0f - g) * (1.0f - g) + 2.0f * g * t;
    return 0.25f * INV_PI_F * (1.0f - g * g) / (denom * sqrt(fmax(denom, 1e-30f)));
}

float eval_phase_hg(float cos_theta, float g) {
    if (fabs(g) < HG_ISOTROPIC_G) return 0.25f * INV_PI_F;
    g = clamp(g, -HG_MAX_G, HG_MAX_G);
    // HG(cos; g) = HG(-cos; -g): measure from the peak of the lobe.
    float t = 1.0f - (g >= 0.0f ? cos_theta : -cos_theta);
    return hg_density(t, fabs(g));
}

// Inverse of the HG CDF for g > 0, as t = 1 - cos_theta. The textbook form
// cos = (1 + g^2 - s^2) / (2g), s = (1 - g^2) / (1 - g + 2gu), simplifies to the product below
// (no subtraction of nearly equal numbers).
float sample_hg_t(float u, float g) {
    float a = 1.0f - g;
    float denom = a + 2.0f * g * u;
    float s = a * (1.0f + g) / denom;
    return a * (1.0f - u) * (s + a) / denom;
}

// A direction around `forward` (the incoming travel direction), and its pdf (the phase value).
float3 sample_phase_hg(float3 forward, float g, float2 u, float* pdf_w) {
    float t, sign;
    g = clamp(g, -HG_MAX_G, HG_MAX_G);
    if (fabs(g) < HG_ISOTROPIC_G) {
        t = 2.0f * u.x;
        sign = 1.0f;
        *pdf_w = 0.25f * INV_PI_F;
    } else {
        t = sample_hg_t(u.x, fabs(g));
        sign = g >= 0.0f ? 1.0f : -1.0f;
        *pdf_w = hg_density(t, fabs(g));
    }
    float cos_theta = sign * (1.0f - t);
    float sin_theta = sqrt(fmax(0.0f, t * (2.0f - t)));
    float s, c;
    sincos_2pi(u.y, &s, &c);
    return to_world((float3)(sin_theta * c, sin_theta * s, cos_theta), forward);
}

#endif
