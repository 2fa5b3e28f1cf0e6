// Small vector helpers and the numeric traps of spawning rays.
#ifndef CLRENDER_MATH_H
#define CLRENDER_MATH_H
#include "lanes.h"

#define PI_F 3.14159265358979323846f
#define INV_PI_F 0.31830988618379067154f
#define LN2_F 0.69314718f

// For the functions the path loop calls once per vertex (surface point, light and BSDF
// sampling, next-event estimation): as calls, their structs go through memory and the loop's
// registers are spilled; inlined, the Cornell box took 7% less time on PoCL. Unoptimised builds
// (-cl-opt-disable: debugging, and Oclgrind, whose LLVM lacks the noalias-scope intrinsic that
// inlining a struct-returning function inserts) keep the calls.
#ifdef __OPTIMIZE__
#define INLINE __attribute__((always_inline))
#else
#define INLINE
#endif

lane_float max_component(lane_float3 v) { return fmax(v.x, fmax(v.y, v.z)); }

float min_component(float3 v) { return fmin(v.x, fmin(v.y, v.z)); }

float mean3(float3 v) { return (v.x + v.y + v.z) * (1.0f / 3.0f); }

// Component c (0, 1, 2) of v: RGB channels picked at run time (spectral MIS's hero channel).
float channel(float3 v, int c) { return c == 0 ? v.x : (c == 1 ? v.y : v.z); }

float luminance(float3 c) { return dot(c, (float3)(0.2126f, 0.7152f, 0.0722f)); }

// A comparison's result (lanes.h).
lane_int is_black(lane_float3 c) { return (c.x == 0.0f) & (c.y == 0.0f) & (c.z == 0.0f); }

// Branchless orthonormal basis around a unit vector (Duff et al. 2017, "Building an Orthonormal
// Basis, Revisited"): no normalisation, no special case except the sign.
void make_basis(lane_float3 n, lane_float3* t, lane_float3* b) {
    lane_float s = select((lane_float)(-1.0f), (lane_float)(1.0f), n.z >= 0.0f);
    lane_float a = -1.0f / (s + n.z);
    lane_float c = n.x * n.y * a;
    *t = make_lane_float3(1.0f + s * n.x * n.x * a, s * c, -s * n.x);
    *b = make_lane_float3(c, s + n.y * n.y * a, -n.y);
}

lane_float3 to_world(lane_float3 v, lane_float3 n) {
    lane_float3 t, b;
    make_basis(n, &t, &b);
    return l3_madd(n, v.z, l3_madd(t, v.x, l3_scale(b, v.y)));
}

// sin and cos of 2*pi*u for u in [0, 1). PoCL's sin/cos are slow (tens of M/s); a minimax
// polynomial on [-pi/4, pi/4] after octant reduction is exact to ~1 ulp for sampling purposes.
void sincos_2pi(lane_float u, lane_float* s, lane_float* c) {
    lane_float x = u * 4.0f;                      // quarter turns
    lane_float q = floor(x + 0.5f);
    lane_float r = (x - q) * (0.5f * PI_F);       // in [-pi/4, pi/4]
    lane_float r2 = r * r;
    lane_float sr = r * (1.0f + r2 * (-1.6666667e-1f + r2 * (8.3333310e-3f + r2 * -1.9840874e-4f)));
    lane_float cr = 1.0f + r2 * (-0.5f + r2 * (4.1666638e-2f + r2 * (-1.3888378e-3f + r2 * 2.4760495e-5f)));
    lane_int quadrant = lane_float_to_int(q) & 3;
    lane_float sv = select(sr, cr, (quadrant & 1) != 0);
    lane_float cv = select(cr, sr, (quadrant & 1) != 0);
    *s = select(sv, -sv, (quadrant & 2) != 0);
    *c = select(cv, -cv, ((quadrant + 1) & 2) != 0);
}

// atan2(y, x) in turns (radians / 2 pi), in [-1/2, 1/2]; 0 at (0, 0). PoCL's atan2 and acos are
// library calls with their own argument reduction; this is Cephes' atanf (about 1 ulp): the
// ratio of the smaller to the larger magnitude, in [0, 1], taken past tan(pi/8) to
// (t - 1) / (t + 1) (an eighth of a turn on), then an odd polynomial, then the octant.
lane_float atan2_turns(lane_float y, lane_float x) {
    lane_float ax = fabs(x), ay = fabs(y);
    lane_float big = fmax(ax, ay), small = fmin(ax, ay);
    lane_float t = select((lane_float)(0.0f), small / big, big > 0.0f);
    lane_int past = t > 0.41421356f;
    lane_float z = select(t, (t - 1.0f) / (t + 1.0f), past);
    lane_float z2 = z * z;
    lane_float a = z + z * z2 * (-3.33329491539e-1f + z2 * (1.99777106478e-1f + z2 * (-1.38776856032e-1f + z2 * 8.05374449538e-2f)));
    a = a * (0.5f * INV_PI_F) + select((lane_float)(0.0f), (lane_float)(0.125f), past);
    a = select(a, 0.25f - a, ay > ax);
    a = select(a, 0.5f - a, x < 0.0f);
    return select(a, -a, y < 0.0f);
}

// exp(x) for x in [-87, 0] as a polynomial (PoCL's exp is as slow as its sin; floor, unlike
// rint, is one instruction): x / ln 2 = n + f with f in [-1/2, 1/2], 2^f by a degree-6
// Chebyshev fit (1e-7 relative in float32), 2^n by the exponent bits. The rounding of x / ln 2
// adds 1e-7 |x| relative.
lane_float exp_fast(lane_float x) {
    lane_float z = x * 1.44269504f;
    lane_float n = floor(z + 0.5f);
    lane_float f = z - n;
    lane_float p = 1.0f + f * (0.69314718f + f * (0.24022651f + f * (0.055503272f + f * (9.6180253e-3f +
                   f * (1.3400442e-3f + f * 1.5469741e-4f)))));
    return p * as_lane_float((lane_float_to_int(n) + 127) << 23);
}

// Offset a ray origin off a surface so that the spawned ray cannot re-hit it, at any scale and
// any distance from the world origin (pbrt-v4 OffsetRayOrigin; Pharr, Jakob and Humphreys,
// "Physically Based Rendering", 4th ed., sec. 6.8.6). n: unit geometric normal on the side the
// new ray leaves towards (the far side for refraction); err: a bound on the error of p along n
// (SurfacePoint.p_error), so the offset is relative to the magnitudes p was computed from. The
// final step to the next float away from p keeps rounding of p + offset from undoing it.
// Waechter and Binder's fixed 256-ulp step (Ray Tracing Gems ch. 6) was used before: it is 0.25
// world units at 1e4 from the origin and a fixed 1.5e-5 near it, neither relative to the scene.
// One float step from p towards the sign of offset: nextafter(p, +-INFINITY) by integer
// arithmetic on the bits (PoCL calls a library routine for nextafter). Stepping away from zero
// adds one to the magnitude's bits, towards zero subtracts one; zero itself steps to the
// smallest float of the offset's sign.
lane_float offset_component(lane_float p, lane_float offset) {
    lane_int away_from_zero = (p > 0.0f) == (offset > 0.0f);
    lane_float stepped = as_lane_float(as_lane_int(p) + select((lane_int)(-1), (lane_int)(1), away_from_zero));
    lane_float from_zero = select((lane_float)(-FLT_MIN), (lane_float)(FLT_MIN), offset > 0.0f);
    return select(select(stepped, from_zero, p == 0.0f), p, offset == 0.0f);
}

lane_float3 offset_ray_origin(lane_float3 p, lane_float3 n, lane_float err) {
    lane_float3 offset = l3_scale(n, err);
    lane_float3 q = l3_add(p, offset);
    return make_lane_float3(offset_component(q.x, offset.x), offset_component(q.y, offset.y),
                            offset_component(q.z, offset.z));
}

#endif
