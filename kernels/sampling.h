// Warps from the unit square and the MIS heuristic. pdf names carry their measure:
// *_pdf_w is per unit solid angle, *_pdf_a per unit area.
#ifndef CLRENDER_SAMPLING_H
#define CLRENDER_SAMPLING_H
#include "math.h"

// Cosine-weighted direction around +z (Malley's method on the unit disk).
lane_float3 sample_cosine_hemisphere(lane_float2 u) {
    lane_float r = sqrt(u.x);
    lane_float s, c;
    sincos_2pi(u.y, &s, &c);
    return make_lane_float3(r * c, r * s, sqrt(fmax(0.0f, 1.0f - u.x)));
}

lane_float sample_cosine_hemisphere_pdf_w(lane_float cos_theta) { return fmax(cos_theta, 0.0f) * INV_PI_F; }

lane_float3 sample_uniform_sphere(lane_float2 u) {
    lane_float z = 1.0f - 2.0f * u.x;
    lane_float r = sqrt(fmax(0.0f, 1.0f - z * z));
    lane_float s, c;
    sincos_2pi(u.y, &s, &c);
    return make_lane_float3(r * c, r * s, z);
}

#define UNIFORM_SPHERE_PDF_W (0.25f * INV_PI_F)

// Uniform on the unit disk by Shirley and Chiu's concentric map, as Mitsuba's
// square_to_uniform_disk_concentric writes it (the same point for the same u): the square's
// concentric squares onto the disk's circles, so a stratified u stays stratified.
lane_float2 sample_concentric_disk(lane_float2 u) {
    lane_float x = 2.0f * u.x - 1.0f, y = 2.0f * u.y - 1.0f;
    lane_int steep = fabs(x) < fabs(y);
    lane_float r = select(x, y, steep), along = select(y, x, steep);
    // The angle in turns, pi/4 along / r or pi/2 less that; 0 at the centre, where it is 0 / 0.
    lane_float turns = 0.125f * along / r;
    turns = select(select(turns, 0.25f - turns, steep), (lane_float)(0.0f), r == 0.0f);
    lane_float s, c;
    sincos_2pi(turns, &s, &c);
    return make_lane_float2(r * c, r * s);
}

// Barycentrics (b1, b2) uniform over a triangle.
lane_float2 sample_triangle(lane_float2 u) {
    lane_float su = sqrt(u.x);
    return make_lane_float2(1.0f - su, u.y * su);
}

// The last i < n with table[at + i] <= u, for non-decreasing entries with table[at] <= u (each
// lane its own `at`). The searched length halves whatever u is, so every lane runs the same
// number of steps and only a select depends on u.
lane_int last_at_most(__global const float* table, lane_int at, int n, lane_float u) {
    lane_int lo = 0;   // invariant: the answer lies in [lo, lo + len), lo + len <= n
    for (int len = n; len > 1;) {
        int step = len >> 1;
        lo = select(lo, lo + step, LANE_LOAD(table, at + lo + step, ) <= u);
        len -= step;
    }
    return lo;
}

// Index i with probability cdf[i+1] - cdf[i] (cdf has n+1 entries, cdf[0] = 0, cdf[n] = 1: the
// last i < n with cdf[i] <= u), and *rescaled: u rescaled to [0, 1) within the chosen interval, a fresh
// uniform number for the chosen item (sample reuse), so one 2D stratified draw both picks and
// places a sample. It keeps log2(p * 2^24) of u's 24 bits for an item of probability p: an item
// chosen less than once in 10^5 gets its numbers on a grid of under 170 steps (as in Mitsuba's
// sample reuse); such items are tiny emitters among very many.
lane_float cdf_rescaled(lane_float u, lane_float low, lane_float high) {
    // clamped: rounding can reach 1, and so can a u beyond a cdf[n] rounded below 1
    return clamp((u - low) / fmax(high - low, 1e-30f), 0.0f, 0x1.fffffep-1f);
}

lane_int sample_discrete_cdf_reuse(__global const float* cdf, int n, lane_float u, lane_float* rescaled) {
    lane_int i = last_at_most(cdf, 0, n, u);
    *rescaled = cdf_rescaled(u, LANE_LOAD(cdf, i, ), LANE_LOAD(cdf, i + 1, ));
    return i;
}

lane_float power_heuristic(lane_float pdf_a, lane_float pdf_b) {
    lane_float a = pdf_a * pdf_a, b = pdf_b * pdf_b;
    // both zero only where neither strategy could have produced the sample
    lane_float weight = select((lane_float)(0.0f), a / (a + b), a + b > 0.0f);
    // A solid-angle pdf past 1.8e19 (a light seen from that far: a vertex deep in a medium with
    // an almost clear channel) squares to infinity, and a / (a + b) to NaN. Then the same weight
    // from the pdfs' ratio, which still sums to 1 with the other technique's.
    lane_int overflow = isinf(a) | isinf(b);
    if (lane_any(overflow)) {
        lane_float r = pdf_b / pdf_a;
        weight = select(weight, 1.0f / (1.0f + r * r), overflow);
    }
    return weight;
}

#endif
