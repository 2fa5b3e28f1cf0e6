// The Beckmann distribution of microfacet normals (Gaussian random surfaces), isotropic:
// D, Smith's Lambda and masking G1, height-correlated masking-shadowing, and sampling of the
// normals visible from wo (VNDF) by Jakob's numerical inversion ("An Improved Visible Normal
// Sampling Routine for the Beckmann Distribution", 2014), as Mitsuba 3 samples it (Mitsuba's
// default distribution). Conventions as in ggx.h, over the lane types (lanes.h) as there; the
// rough lobes reach it through materials/microfacet.h.
#ifndef CLRENDER_BECKMANN_H
#define CLRENDER_BECKMANN_H
#include "lanes.h"
#include "math.h"
#if DIELECTRIC

#define SQRT_PI_F 1.77245385090551603f
#define INV_SQRT_PI_F 0.56418958354775628f

// The inverse error function on (-1, 1), single precision (Giles 2010, "Approximating the erfinv
// function"; the approximation Mitsuba's Dr.Jit uses). OpenCL C has erf but no inverse.
// Lanes with w < 5 take the central polynomial, the others the tail's; a branch skips the one no
// lane needs.
lane_float inverse_erf(lane_float x) {
    lane_float w = -log((1.0f - x) * (1.0f + x));
    lane_int central = w < 5.0f;
    lane_float p = 0.0f;
    if (lane_any(central)) {
        lane_float v = w - 2.5f;
        lane_float q = 2.81022636e-08f;
        q = 3.43273939e-07f + q * v;
        q = -3.5233877e-06f + q * v;
        q = -4.39150654e-06f + q * v;
        q = 0.00021858087f + q * v;
        q = -0.00125372503f + q * v;
        q = -0.00417768164f + q * v;
        q = 0.246640727f + q * v;
        q = 1.50140941f + q * v;
        p = q;
    }
    if (lane_any(!central)) {
        lane_float v = sqrt(w) - 3.0f;
        lane_float q = -0.000200214257f;
        q = 0.000100950558f + q * v;
        q = 0.00134934322f + q * v;
        q = -0.00367342844f + q * v;
        q = 0.00573950773f + q * v;
        q = -0.0076224613f + q * v;
        q = 0.00943887047f + q * v;
        q = 1.00167406f + q * v;
        q = 2.83297682f + q * v;
        p = select(p, q, !central);
    }
    return p * x;
}

// D(h) = exp(-tan^2 / alpha^2) / (pi alpha^2 cos^4) (Walter et al. 2007, eq. 25); tan^2 from a
// cross product, as in ggx_d.
lane_float beckmann_d(lane_float3 n, lane_float3 h, lane_float alpha) {
    lane_float cos_h = l3_dot(n, h);
    lane_float3 s = l3_cross(n, h);
    lane_float c2 = cos_h * cos_h, a2 = alpha * alpha;
    return select((lane_float)(0.0f), exp(-l3_dot(s, s) / (c2 * a2)) / (PI_F * a2 * c2 * c2), cos_h > 0.0f);
}

// Beyond this a (= cot / alpha) Lambda < 1.5e-8, so 1 + Lambda (and 1 + Lambda_o + Lambda_i)
// rounds to 1 in float32: G1 and G2 are 1 without their exp and erfc (most directions of a
// nearly smooth surface).
#define BECKMANN_LAMBDA_NEGLIGIBLE_A 3.5f

// Smith's Lambda for a direction at cos_w (Walter et al. 2007, eq. 27): with a = cot / alpha,
// Lambda = (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2 = exp(-a^2) g(a) / (2 sqrt(pi) a), where
// g(a) = 1 - sqrt(pi) a exp(a^2) erfc(a) is smooth from 1 at a = 0 to 0.04 at a = 3.5, here a
// polynomial of degree 7 in t = 1 / (1 + a / 2) (least squares in float64 over [0, 3.5]; relative
// error below 1e-6, G1 within 2e-7 of float64's, as the float32 erfc form was within 1.1e-7): one
// exp and no erfc, which was a twentieth of ppg-torus's render. Infinite at grazing incidence
// (a = 0), where beckmann_g1 and beckmann_g2 return 0.
lane_float beckmann_lambda(lane_float cos_w, lane_float alpha) {
    lane_float c = fabs(cos_w);
    lane_float s = sqrt(fmax(0.0f, 1.0f - c * c));
    lane_float a = c / (alpha * s);
    lane_int negligible = (s == 0.0f) | (a > BECKMANN_LAMBDA_NEGLIGIBLE_A);
    if (!lane_any(!negligible)) return 0.0f;
    lane_float t = 1.0f / (1.0f + 0.5f * a);
    lane_float g = -0.0024000693f + t * (0.037167393f + t * (-0.12328485f + t * (1.1788671f + t * (-1.7721467f
                   + t * (3.1555519f + t * (-1.8448677f + t * 0.37111345f))))));
    return select((0.5f * INV_SQRT_PI_F) * exp(-a * a) * g / a, (lane_float)(0.0f), negligible);
}

// Smith masking of one direction: G1 = 1 / (1 + Lambda).
lane_float beckmann_g1(lane_float cos_w, lane_float alpha) {
    return select(1.0f / (1.0f + beckmann_lambda(cos_w, alpha)), (lane_float)(0.0f), cos_w == 0.0f);
}

// Height-correlated masking-shadowing (Heitz 2014, eq. 99): G2 = 1 / (1 + Lambda_o + Lambda_i).
lane_float beckmann_g2(lane_float cos_o, lane_float cos_i, lane_float alpha) {
    return select(1.0f / (1.0f + beckmann_lambda(cos_o, alpha) + beckmann_lambda(cos_i, alpha)), (lane_float)(0.0f),
                  (cos_o == 0.0f) | (cos_i == 0.0f));
}

// Below this tan_theta the visible slopes are nearly the Gaussian of normal incidence.
#define BECKMANN_NEAR_NORMAL_TAN 0.05f

// Near normal incidence, the first slope's root of erf(s) + tan / sqrt(pi) exp(-s^2) = 2 u - 1
// as a series in a = tan / 2 around the normal-incidence root s0 = erfinv(2 u - 1), to a^7 (its
// terms solved symbolically; float64 study over u in [1e-6, 1 - 1e-6] and tan <= 0.05: slope
// error < 7.6e-9, below a float32 slope's rounding): no Newton steps, whose erfinv and exp were
// a tenth of ppg-torus's render (docs/performance.md).
lane_float beckmann_near_normal_slope(lane_float s0, lane_float a) {
    lane_float s2 = s0 * s0;
    lane_float c3 = (2.0f / 3.0f) * (2.0f * s2 - 1.0f);
    lane_float c4 = 0.5f * s0 * (4.0f * s2 - 5.0f);
    lane_float c5 = (8.0f / 15.0f) * (s2 - 2.0f) * (6.0f * s2 - 1.0f);
    lane_float c6 = s0 * ((96.0f * s2 - 308.0f) * s2 + 127.0f) * (1.0f / 18.0f);
    lane_float c7 = (8.0f / 105.0f) * (((120.0f * s2 - 522.0f) * s2 + 391.0f) * s2 - 29.0f);
    return s0 - a * (1.0f + a * (s0 + a * (c3 + a * (c4 + a * (c5 + a * (c6 + a * c7))))));
}

// The slopes of a visible normal of the unit-width distribution seen at cos_theta (Mitsuba 3's
// sample_visible_11: Jakob 2014). The marginal CDF of the first slope, in the erf domain x, is
// inverted by Newton steps from the analytic solution at grazing incidence, or near normal
// incidence by beckmann_near_normal_slope; the second slope is Gaussian. u is clamped away from
// 0 and 1, where the inverse is infinite. Lanes near normal incidence and the others each take
// their way; a branch skips the way no lane takes.
lane_float2 sample_beckmann_visible_11(lane_float cos_theta, lane_float2 u) {
    lane_float c = clamp(cos_theta, 1e-6f, 1.0f);
    lane_float tan_theta = sqrt(fmax(0.0f, 1.0f - c * c)) / c;
    lane_float ux = clamp(u.x, 1e-6f, 1.0f - 1e-6f), uy = clamp(u.y, 1e-6f, 1.0f - 1e-6f);
    lane_float second = inverse_erf(2.0f * uy - 1.0f);
    lane_int near_normal = tan_theta < BECKMANN_NEAR_NORMAL_TAN;
    lane_float first = 0.0f;
    if (lane_any(near_normal)) first = beckmann_near_normal_slope(inverse_erf(2.0f * ux - 1.0f), 0.5f * tan_theta);
    if (!lane_any(!near_normal)) return make_lane_float2(first, second);
    lane_float cot_theta = c / sqrt(fmax(1e-12f, 1.0f - c * c));
    // Beyond cot 4, erf rounds to 1 and the exp term vanishes against 1 + max_x = 2 (< 2e-8).
    lane_int steep = cot_theta >= 4.0f;
    lane_float max_x = select(erf(cot_theta), (lane_float)(1.0f), steep);
    // x stays inside (-1, 1), where inverse_erf is finite: an erf within its allowed 2 ulp of 1
    // (Intel's, at u.x = 1e-6) would put x at -1 exactly.
    const float x_limit = 0.99999988f;   // the largest float below 1
    lane_float x = clamp(max_x - (max_x + 1.0f) * erf(sqrt(-log(ux))), -x_limit, x_limit);
    lane_float target = ux * select(1.0f + max_x + INV_SQRT_PI_F * tan_theta * exp(-cot_theta * cot_theta),
                                    (lane_float)(2.0f), steep);
    for (int i = 0; i < 3; ++i) {
        lane_float slope = inverse_erf(x);
        lane_float value = 1.0f + x + INV_SQRT_PI_F * tan_theta * exp(-slope * slope) - target;
        x = clamp(x - value / (1.0f - slope * tan_theta), -x_limit, x_limit);
    }
    return make_lane_float2(select(inverse_erf(x), first, near_normal), second);
}

// A microfacet normal visible from wo, distributed as sample_microfacet_visible_pdf: stretch
// wo to unit width, sample the slopes there along wo's azimuth, rotate and unstretch them
// (Heitz and d'Eon 2014, "Importance Sampling Microfacet-Based BSDFs using the Distribution of
// Visible Normals", sec. 4).
lane_float3 sample_beckmann_vndf(lane_float3 n, lane_float3 wo, lane_float alpha, lane_float2 u) {
    lane_float3 t, b;
    make_basis(n, &t, &b);
    lane_float3 ws = l3_normalize(make_lane_float3(alpha * l3_dot(wo, t), alpha * l3_dot(wo, b),
                                                   fmax(l3_dot(wo, n), 0.0f)));
    lane_float len2 = ws.x * ws.x + ws.y * ws.y;
    lane_int tilted = len2 > 0.0f;
    lane_float inv_len = select((lane_float)(0.0f), rsqrt(len2), tilted);
    lane_float cos_phi = select((lane_float)(1.0f), ws.x * inv_len, tilted), sin_phi = ws.y * inv_len;
    lane_float2 slope = sample_beckmann_visible_11(ws.z, u);
    lane_float sx = alpha * (cos_phi * slope.x - sin_phi * slope.y);
    lane_float sy = alpha * (sin_phi * slope.x + cos_phi * slope.y);
    lane_float3 hl = l3_normalize(make_lane_float3(-sx, -sy, (lane_float)(1.0f)));
    return l3_add(l3_add(l3_scale(t, hl.x), l3_scale(b, hl.y)), l3_scale(n, hl.z));
}

#endif
#endif
