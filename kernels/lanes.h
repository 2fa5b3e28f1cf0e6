// The lane type of the kernel's per-path values: LANES paths per work-item. LANES 1 (the default,
// and what GPUs run) makes every lane type a plain scalar or vector type, so code written over
// them compiles to what it would be without them; LANES 8 keeps 8 paths in float8 lanes (SIMD
// across rays on CPUs, docs/performance.md). Integer and float arithmetic, comparisons and
// select() are written the same for both (a condition as a comparison, `m != 0`, never a bare
// integer: vector select and ?: read a lane's sign bit, scalar ones any non-zero value);
// conversions and three-component values go through the helpers below. lane_float2 and
// lane_float3 have members .x, .y (and .z) either way.
#ifndef CLRENDER_LANES_H
#define CLRENDER_LANES_H

#ifndef LANES
#define LANES 1
#endif

#if LANES == 1
typedef float lane_float;
typedef uint lane_uint;
typedef int lane_int;
typedef float2 lane_float2;
typedef float3 lane_float3;
#define lane_uint_to_float(x) ((float)(x))
#define lane_float_to_int(x) ((int)(x))
#define lane_int_to_float(x) ((float)(x))
#define as_lane_float(x) as_float(x)
#define as_lane_int(x) as_int(x)
// Whether any lane's mask (a comparison's result) is set.
#define lane_any(m) ((m) != 0)
// Whether every lane's mask is set.
#define lane_all(m) ((m) != 0)
// A set lane mask, as comparisons give it.
#define LANE_TRUE 1
// Each lane's index, 0 .. LANES - 1.
#define LANE_INDEX 0
// The lanes' values from LANES consecutive floats of private memory, and back.
#define lane_vload(p) (*(p))
#define lane_vstore(v, p) (*(p) = (v))
// Macros, not functions, for one lane: the expressions are then the ones written inline before,
// and the compiler contracts a * b + c into fma exactly as it did (it contracts within an
// expression only, so a function boundary would change the rounding).
#define make_lane_float2(x, y) ((float2)((x), (y)))
#define make_lane_float3(x, y, z) ((float3)((x), (y), (z)))
#define l3_splat(s) ((float3)(s))
// The same float3 in every lane.
#define l3_uniform(v) (v)
#define l3_add(a, b) ((a) + (b))
#define l3_sub(a, b) ((a) - (b))
#define l3_mul(a, b) ((a) * (b))
#define l3_scale(a, s) ((a) * (s))
#define l3_div(a, s) ((a) / (s))
#define l3_div3(a, b) ((a) / (b))
#define l3_madd(a, s, c) ((a) * (s) + (c))
#define l3_neg(a) (-(a))
#define l3_abs(a) fabs(a)
#define l3_dot(a, b) dot((a), (b))
#define l3_cross(a, b) cross((a), (b))
#define l3_normalize(a) normalize(a)
#define l3_length(a) length(a)
#define l3_select(a, b, m) ((m) != 0 ? (b) : (a))
#define l3_mix(a, b, t) mix((a), (b), (t))
// Per-lane loads of element INDEX of ARRAY, then FIELD (a member path such as .v0.x, or
// nothing): LANE_LOAD a float, LANE_LOAD_INT an int, LANE_LOAD3 a float4 member's xyz.
#define LANE_LOAD(ARRAY, INDEX, FIELD) ((ARRAY)[INDEX] FIELD)
#define LANE_LOAD_INT(ARRAY, INDEX, FIELD) ((ARRAY)[INDEX] FIELD)
#define LANE_LOAD3(ARRAY, INDEX, FIELD) ((ARRAY)[INDEX] FIELD.xyz)
#elif LANES == 8
typedef float8 lane_float;
typedef uint8 lane_uint;
typedef int8 lane_int;
typedef struct { float8 x, y; } lane_float2;
typedef struct { float8 x, y, z; } lane_float3;
#define lane_uint_to_float(x) convert_float8(x)
#define lane_float_to_int(x) convert_int8(x)
#define lane_int_to_float(x) convert_float8(x)
#define as_lane_float(x) as_float8(x)
#define as_lane_int(x) as_int8(x)
#define lane_any(m) any(m)
#define lane_all(m) all(m)
#define LANE_TRUE ((int8)(-1))
#define LANE_INDEX ((int8)(0, 1, 2, 3, 4, 5, 6, 7))
#define lane_vload(p) vload8(0, (p))
#define lane_vstore(v, p) vstore8((v), 0, (p))
lane_float2 make_lane_float2(float8 x, float8 y) { lane_float2 v = {x, y}; return v; }
lane_float3 make_lane_float3(float8 x, float8 y, float8 z) { lane_float3 v = {x, y, z}; return v; }
lane_float3 l3_splat(float s) { return make_lane_float3((float8)(s), (float8)(s), (float8)(s)); }
lane_float3 l3_uniform(float3 v) { return make_lane_float3((float8)(v.x), (float8)(v.y), (float8)(v.z)); }
lane_float3 l3_add(lane_float3 a, lane_float3 b) { return make_lane_float3(a.x + b.x, a.y + b.y, a.z + b.z); }
lane_float3 l3_sub(lane_float3 a, lane_float3 b) { return make_lane_float3(a.x - b.x, a.y - b.y, a.z - b.z); }
lane_float3 l3_mul(lane_float3 a, lane_float3 b) { return make_lane_float3(a.x * b.x, a.y * b.y, a.z * b.z); }
lane_float3 l3_scale(lane_float3 a, float8 s) { return make_lane_float3(a.x * s, a.y * s, a.z * s); }
lane_float3 l3_div(lane_float3 a, float8 s) { return make_lane_float3(a.x / s, a.y / s, a.z / s); }
lane_float3 l3_div3(lane_float3 a, lane_float3 b) { return make_lane_float3(a.x / b.x, a.y / b.y, a.z / b.z); }
lane_float3 l3_madd(lane_float3 a, float8 s, lane_float3 c) {
    return make_lane_float3(fma(a.x, s, c.x), fma(a.y, s, c.y), fma(a.z, s, c.z));
}
lane_float3 l3_neg(lane_float3 a) { return make_lane_float3(-a.x, -a.y, -a.z); }
lane_float3 l3_abs(lane_float3 a) { return make_lane_float3(fabs(a.x), fabs(a.y), fabs(a.z)); }
lane_float l3_dot(lane_float3 a, lane_float3 b) { return fma(a.x, b.x, fma(a.y, b.y, a.z * b.z)); }
lane_float3 l3_cross(lane_float3 a, lane_float3 b) {
    return make_lane_float3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
lane_float3 l3_normalize(lane_float3 a) { return l3_scale(a, rsqrt(l3_dot(a, a))); }
lane_float l3_length(lane_float3 a) { return sqrt(l3_dot(a, a)); }
lane_float3 l3_select(lane_float3 a, lane_float3 b, int8 m) {
    return make_lane_float3(select(a.x, b.x, m), select(a.y, b.y, m), select(a.z, b.z, m));
}
lane_float3 l3_mix(lane_float3 a, lane_float3 b, float8 t) {
    return make_lane_float3(mix(a.x, b.x, t), mix(a.y, b.y, t), mix(a.z, b.z, t));
}
#define LANE_EACH_(ARRAY, INDEX, FIELD) ((ARRAY)[(INDEX).s0] FIELD, (ARRAY)[(INDEX).s1] FIELD, \
    (ARRAY)[(INDEX).s2] FIELD, (ARRAY)[(INDEX).s3] FIELD, (ARRAY)[(INDEX).s4] FIELD, \
    (ARRAY)[(INDEX).s5] FIELD, (ARRAY)[(INDEX).s6] FIELD, (ARRAY)[(INDEX).s7] FIELD)
#define LANE_LOAD(ARRAY, INDEX, FIELD) ((float8)LANE_EACH_(ARRAY, INDEX, FIELD))
#define LANE_LOAD_INT(ARRAY, INDEX, FIELD) ((int8)LANE_EACH_(ARRAY, INDEX, FIELD))
#define LANE_LOAD3(ARRAY, INDEX, FIELD) make_lane_float3(LANE_LOAD(ARRAY, INDEX, FIELD.x), \
    LANE_LOAD(ARRAY, INDEX, FIELD.y), LANE_LOAD(ARRAY, INDEX, FIELD.z))
#else
#error "LANES must be 1 or 8"
#endif

#endif
