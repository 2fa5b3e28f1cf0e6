// The lane type of the kernel's per-path values: LANES paths per work-item. LANES 1 (the default,
// and what GPUs run) makes every lane type a plain scalar or vector type, so code written over
// them compiles to what it would be without them; LANES 8 keeps 8 paths in float8 lanes (SIMD
// across rays on CPUs, docs/performance.md). Integer and float arithmetic, comparisons and
// select() are written the same for both; conversions and two-component values go through the
// helpers below. lane_float2 has members .x and .y either way.
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
#define lane_uint_to_float(x) ((float)(x))
lane_float2 make_lane_float2(float x, float y) { return (float2)(x, y); }
#elif LANES == 8
typedef float8 lane_float;
typedef uint8 lane_uint;
typedef int8 lane_int;
typedef struct { float8 x, y; } lane_float2;
#define lane_uint_to_float(x) convert_float8(x)
lane_float2 make_lane_float2(float8 x, float8 y) { lane_float2 v = {x, y}; return v; }
#else
#error "LANES must be 1 or 8"
#endif

#endif
