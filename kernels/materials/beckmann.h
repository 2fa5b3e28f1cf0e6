// The Beckmann distribution of microfacet normals (Gaussian random surfaces), isotropic:
// D, Smith's Lambda and masking G1, height-correlated masking-shadowing, and sampling of the
// normals visible from wo (VNDF) by Jakob's numerical inversion ("An Improved Visible Normal
// Sampling Routine for the Beckmann Distribution", 2014), as Mitsuba 3 samples it (Mitsuba's
// default distribution). Conventions as in ggx.h; the rough lobes reach it through
// materials/microfacet.h.
#ifndef CLRENDER_BECKMANN_H
#define CLRENDER_BECKMANN_H
#include "math.h"
#if DIELECTRIC

#define SQRT_PI_F 1.77245385090551603f
#define INV_SQRT_PI_F 0.56418958354775628f

// The inverse error function on (-1, 1), single precision (Giles 2010, "Approximating the erfinv
// function"; the approximation Mitsuba's Dr.Jit uses). OpenCL C has erf but no inverse.
float inverse_erf(float x) {
    float w = -log((1.0f - x) * (1.0f + x));
    float p;
    if (w < 5.0f) {
        w -= 2.5f;
        p = 2.81022636e-08f;
        p = 3.43273939e-07f + p * w;
        p = -3.5233877e-06f + p * w;
        p = -4.39150654e-06f + p * w;
        p = 0.00021858087f + p * w;
        p = -0.00125372503f + p * w;
        p = -0.00417768164f + p * w;
        p = 0.246640727f + p * w;
        p = 1.50140941f + p * w;
    } else {
        w = sqrt(w) - 3.0f;
        p = -0.000200214257f;
        p = 0.000100950558f + p * w;
        p = 0.00134934322f + p * w;
        p = -0.00367342844f + p * w;
        p = 0.00573950773f + p * w;
        p = -0.0076224613f + p * w;
        p = 0.00943887047f + p * w;
        p = 1.00167406f + p * w;
        p = 2.83297682f + p * w;
    }
    return p * x;
}

// D(h) = exp(-tan^2 / alpha^2) / (pi alpha^2 cos^4) (Walter et al. 2007, eq. 25); tan^2 from a
// cross product, as in ggx_d.
float beckmann_d(float3 n, float3 h, float alpha) {
    float cos_h = dot(n, h);
    if (cos_h <= 0.0f) return 0.0f;
    float3 s = cross(n, h);
    float c2 = cos_h * cos_h, a2 = alpha * alpha;
    return exp(-dot(s, s) / (c2 * a2)) / (PI_F * a2 * c2 * c2);
}

// Beyond this a (= cot / alpha) Lambda < 1.5e-8, so 1 + Lambda (and 1 + Lambda_o + Lambda_i)
// rounds to 1 in float32: G1 and G2 are 1 without their exp and erfc (most directions of a
// nearly smooth surface).
#define BECKMANN_LAMBDA_NEGLIGIBLE_A 3.5f

// Smith's Lambda for a direction at cos_w (Walter et al. 2007, eq. 27, with erf(a) - 1 written as
// -erfc(a), which keeps its digits where Lambda is small): a = cot / alpha,
// Lambda = (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2. 0 at normal incidence; at grazing
// incidence Lambda is infinite and G1 0, returned as such by beckmann_g1 and beckmann_g2.
float beckmann_lambda(float cos_w, float alpha) {
    float c = fabs(cos_w);
    float s = sqrt(fmax(0.0f, 1.0f - c * c));
    if (s == 0.0f) return 0.0f;
    float a = c / (alpha * s);
    if (a > BECKMANN_LAMBDA_NEGLIGIBLE_A) return 0.0f;
    return 0.5f * (exp(-a * a) * INV_SQRT_PI_F / a - erfc(a));
}

// Smith masking of one direction: G1 = 1 / (1 + Lambda).
float beckmann_g1(float cos_w, float alpha) {
    return cos_w == 0.0f ? 0.0f : 1.0f / (1.0f + beckmann_lambda(cos_w, alpha));
}

// Height-correlated masking-shadowing (Heitz 2014, eq. 99): G2 = 1 / (1 + Lambda_o + Lambda_i).
float beckmann_g2(float cos_o, float cos_i, float alpha) {
    if (cos_o == 0.0f || cos_i == 0.0f) return 0.0f;
    return 1.0f / (1.0f + beckmann_lambda(cos_o, alpha) + beckmann_lambda(cos_i, alpha));
}

// Below this tan_theta the visible slopes are nearly the Gaussian of normal incidence.
#define BECKMANN_NEAR_NORMAL_TAN 0.05f

// Near normal incidence, the first slope's root of erf(s) + tan / sqrt(pi) exp(-s^2) = 2 u - 1
// as a series in a = tan / 2 around the normal-incidence root s0 = erfinv(2 u - 1), to a^7 (its
// terms solved symbolically; float64 study over u in [1e-6, 1 - 1e-6] and tan <= 0.05: slope
// error < 7.6e-9, below a float32 slope's rounding): no Newton steps, whose erfinv and exp were
// a tenth of ppg-torus's render (docs/performance.md).
float beckmann_near_normal_slope(float s0, float a) {
    float s2 = s0 * s0;
    float c3 = (2.0f / 3.0f) * (2.0f * s2 - 1.0f);
    float c4 = 0.5f * s0 * (4.0f * s2 - 5.0f);
    float c5 = (8.0f / 15.0f) * (s2 - 2.0f) * (6.0f * s2 - 1.0f);
    float c6 = s0 * ((96.0f * s2 - 308.0f) * s2 + 127.0f) * (1.0f / 18.0f);
    float c7 = (8.0f / 105.0f) * (((120.0f * s2 - 522.0f) * s2 + 391.0f) * s2 - 29.0f);
    return s0 - a * (1.0f + a * (s0 + a * (c3 + a * (c4 + a * (c5 + a * (c6 + a * c7))))));
}

// The slopes of a visible normal of the unit-width distribution seen at cos_theta (Mitsuba 3's
// sample_visible_11: Jakob 2014). The marginal CDF of the first slope, in the erf domain x, is
// inverted by Newton steps from the analytic solution at grazing incidence, or near normal
// incidence by beckmann_near_normal_slope; the second slope is Gaussian. u is clamped away from
// 0 and 1, where the inverse is infinite.
float2 sample_beckmann_visible_11(float cos_theta, float2 u) {
    float c = clamp(cos_theta, 1e-6f, 1.0f);
    float tan_theta = sqrt(fmax(0.0f, 1.0f - c * c)) / c;
    u = clamp(u, 1e-6f, 1.0f - 1e-6f);
    float second = inverse_erf(2.0f * u.y - 1.0f);
    if (tan_theta < BECKMANN_NEAR_NORMAL_TAN)
        return (float2)(beckmann_near_normal_slope(inverse_erf(2.0f * u.x - 1.0f), 0.5f * tan_theta), second);
    float cot_theta = c / sqrt(fmax(1e-12f, 1.0f - c * c));
    // Beyond cot 4, erf rounds to 1 and the exp term vanishes against 1 + max_x = 2 (< 2e-8).
    bool steep = cot_theta >= 4.0f;
    float max_x = steep ? 1.0f : erf(cot_theta);
    // x stays inside (-1, 1), where inverse_erf is finite: an erf within its allowed 2 ulp of 1
    // (Intel's, at u.x = 1e-6) would put x at -1 exactly.
    const float x_limit = 0.99999988f;   // the largest float below 1
    float x = clamp(max_x - (max_x + 1.0f) * erf(sqrt(-log(u.x))), -x_limit, x_limit);
    float target = u.x * (steep ? 2.0f : 1.0f + max_x + INV_SQRT_PI_F * tan_theta * exp(-cot_theta * cot_theta));
    for (int i = 0; i < 3; ++i) {
        float slope = inverse_erf(x);
        float value = 1.0f + x + INV_SQRT_PI_F * tan_theta * exp(-slope * slope) - target;
        x = clamp(x - value / (1.0f - slope * tan_theta), -x_limit, x_limit);
    }
    return (float2)(inverse_erf(x), second);
}

// A microfacet normal visible from wo, distributed as sample_microfacet_visible_pdf: stretch
// wo to unit width, sample the slopes there along wo's azimuth, rotate and unstretch them
// (Heitz and d'Eon 2014, "Importance Sampling Microfacet-Based BSDFs using the Distribution of
// Visible Normals", sec. 4).
float3 sample_beckmann_vndf(float3 n, float3 wo, float alpha, float2 u) {
    float3 t, b;
    make_basis(n, &t, &b);
    float3 ws = normalize((float3)(alpha * dot(wo, t), alpha * dot(wo, b), fmax(dot(wo, n), 0.0f)));
    float len2 = ws.x * ws.x + ws.y * ws.y;
    float inv_len = len2 > 0.0f ? rsqrt(len2) : 0.0f;
    float cos_phi = len2 > 0.0f ? ws.x * inv_len : 1.0f, sin_phi = ws.y * inv_len;
    float2 slope = sample_beckmann_visible_11(ws.z, u);
    float sx = alpha * (cos_phi * slope.x - sin_phi * slope.y);
    float sy = alpha * (sin_phi * slope.x + cos_phi * slope.y);
    float3 hl = normalize((float3)(-sx, -sy, 1.0f));
    return hl.x * t + hl.y * b + hl.z * n;
}

#endif
#endif
