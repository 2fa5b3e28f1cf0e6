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
lane_float2 make_lane_float2(float x, float y) { return (float2)(x, y); }
lane_float3 make_lane_float3(float x, float y, float z) { return (float3)(x, y, z); }
lane_float3 l3_splat(float s) { return (float3)(s); }
lane_float3 l3_add(float3 a, float3 b) { return a + b; }
lane_float3 l3_sub(float3 a, float3 b) { return a - b; }
lane_float3 l3_mul(float3 a, float3 b) { return a * b; }
lane_float3 l3_scale(float3 a, float s) { return a * s; }
lane_float3 l3_madd(float3 a, float s, float3 c) { return a * s + c; }   // one expression: contracted to fma like inline code
lane_float l3_dot(float3 a, float3 b) { return dot(a, b); }
lane_float3 l3_cross(float3 a, float3 b) { return cross(a, b); }
lane_float3 l3_normalize(float3 a) { return normalize(a); }
lane_float3 l3_select(float3 a, float3 b, int m) { return m != 0 ? b : a; }
#elif LANES == 8
typedef float8 lane_float;
typedef uint8 lane_uint;
typedef int8 lane_int;
typedef struct { float8 x, y; } lane_float2;
typedef struct { float8 x, y, z; } lane_float3;
#define lane_uint_to_float(x) convert_float8(x)
#define lane_float_to_int(x) convert_int8(x)
lane_float2 make_lane_float2(float8 x, float8 y) { lane_float2 v = {x, y}; return v; }
lane_float3 make_lane_float3(float8 x, float8 y, float8 z) { lane_float3 v = {x, y, z}; return v; }
lane_float3 l3_splat(float s) { return make_lane_float3((float8)(s), (float8)(s), (float8)(s)); }
lane_float3 l3_add(lane_float3 a, lane_float3 b) { return make_lane_float3(a.x + b.x, a.y + b.y, a.z + b.z); }
lane_float3 l3_sub(lane_float3 a, lane_float3 b) { return make_lane_float3(a.x - b.x, a.y - b.y, a.z - b.z); }
lane_float3 l3_mul(lane_float3 a, lane_float3 b) { return make_lane_float3(a.x * b.x, a.y * b.y, a.z * b.z); }
lane_float3 l3_scale(lane_float3 a, float8 s) { return make_lane_float3(a.x * s, a.y * s, a.z * s); }
lane_float3 l3_madd(lane_float3 a, float8 s, lane_float3 c) { return make_lane_float3(fma(a.x, s, c.x), fma(a.y, s, c.y), fma(a.z, s, c.z)); }
lane_float l3_dot(lane_float3 a, lane_float3 b) { return fma(a.x, b.x, fma(a.y, b.y, a.z * b.z)); }
lane_float3 l3_cross(lane_float3 a, lane_float3 b) {
    return make_lane_float3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
lane_float3 l3_normalize(lane_float3 a) { return l3_scale(a, rsqrt(l3_dot(a, a))); }
lane_float3 l3_select(lane_float3 a, lane_float3 b, int8 m) {
    return make_lane_float3(select(a.x, b.x, m), select(a.y, b.y, m), select(a.z, b.z, m));
}
#else
#error "LANES must be 1 or 8"
#endif

#endif
