// The gather of splatting (splat.h): one work-item per LANES adjacent pixels of a row of the
// target tile (params->splat; lanes.h: 8 on CPUs, in the vector lanes, 1 elsewhere) adds the
// records of the pass's samples (params->frame.w of them) of the traced pixels (params->tile)
// within the filter's reach to their sums: xyz sum of w L, w sum of w. Each pixel adds its
// neighbours' records in the same order (sample, then row, then column) whatever LANES is.
// sum_samples, below, serves sample items (integrator.cl): a pixel's own records into its
// accumulator.
#include "portability.h"
#include "lanes.h"
#include "types.h"
#include "splat.h"
#include "aov_sums.h"

// Element q of `a` in each lane: one vector load where the lanes' indices are consecutive (all
// but a row's first and last work-items, whose neighbours beyond the traced pixels are clamped).
lane_float load_record_lanes(__global const float* a, lane_int q) {
#if LANES == 1
    return a[q];
#else
    return q.s7 - q.s0 == 7 ? vload8(0, a + q.s0) : LANE_LOAD(a, q, );
#endif
}

KERNEL void gather_splats(__constant RenderParams* params, __global const float* records, __global float4* filtered) {
    int first = get_global_id(0) * LANES, ty = get_global_id(1);
    int4 target = params->splat, traced = params->tile;
    if (first >= target.z || ty >= target.w) return;
    int lanes = min(LANES, target.z - first);
    lane_int x = target.x + first + LANE_INDEX;
    int y = target.y + ty;
    int reach = params->splat_reach.x;
    int pixels = traced.z * traced.w;
    __global float4* out = filtered + ty * target.z + first;
    float start[4][LANES];
    for (int i = 0; i < LANES; ++i) {
        float4 sum = i < lanes ? out[i] : (float4)(0.0f);
        start[0][i] = sum.x; start[1][i] = sum.y; start[2][i] = sum.z; start[3][i] = sum.w;
    }
    lane_float sum_r = lane_vload(start[0]), sum_g = lane_vload(start[1]), sum_b = lane_vload(start[2]);
    lane_float sum_w = lane_vload(start[3]);
    lane_int lowest = (lane_int)(traced.x), highest = (lane_int)(traced.x + traced.z - 1);
    for (int s = 0; s < params->frame.w; ++s) {
        __global const float* pass = records + s * SPLAT_COMPONENTS(reach) * pixels;
        for (int dy = -reach; dy <= reach; ++dy) {
            int qy = y + dy;
            if (qy < traced.y || qy >= traced.y + traced.w) continue;   // outside the image: weight 0
            __global const float* row = pass + (qy - traced.y) * traced.z - traced.x;
            // This pixel is -dy rows from the neighbour's, -dx columns.
            __global const float* y_weights = row + (SPLAT_Y_WEIGHT(reach) + reach - dy) * pixels;
            for (int dx = -reach; dx <= reach; ++dx) {
                lane_int qx = x + dx;
                lane_int q = clamp(qx, lowest, highest);
                lane_float w = load_record_lanes(row + (SPLAT_X_WEIGHT + reach - dx) * pixels, q) *
                               load_record_lanes(y_weights, q);
                w = select((lane_float)(0.0f), w, qx == q);   // neighbours outside the image weigh 0
                sum_r += load_record_lanes(row, q) * w;
                sum_g += load_record_lanes(row + pixels, q) * w;
                sum_b += load_record_lanes(row + 2 * pixels, q) * w;
                sum_w += w;
            }
        }
    }
    lane_vstore(sum_r, start[0]);
    lane_vstore(sum_g, start[1]);
    lane_vstore(sum_b, start[2]);
    lane_vstore(sum_w, start[3]);
    for (int i = 0; i < lanes; ++i) out[i] = (float4)(start[0][i], start[1][i], start[2][i], start[3][i]);
}

// After a pass of sample items (integrator.cl): each traced pixel adds its own records' radiance
// to its accumulator in sample order, as the render pass's loop adds them; with AOVS, the
// records' AOVs and the colour's deviations to its AOV sums too (aov_sums.h, as the loop adds
// them).
KERNEL void sum_samples(__constant RenderParams* params, __global const float* records, __global float4* accumulator
#if AOVS
                        , __global const AovSums* aov_records, __global AovSums* aov_sums
#endif
                        ) {
    int tx = get_global_id(0), ty = get_global_id(1);
    int4 traced = params->tile;
    if (tx >= traced.z || ty >= traced.w) return;
    int pixels = traced.z * traced.w;
    int slot = ty * traced.z + tx;
    __global const float* record = records + slot;
    float4 sum = accumulator[slot];
#if AOVS
    AovSums aovs = aov_sums[slot];
#endif
    for (int s = 0; s < params->frame.w; ++s, record += SPLAT_COMPONENTS(params->splat_reach.x) * pixels) {
        float3 value = (float3)(record[0], record[pixels], record[2 * pixels]);
#if AOVS
        AovSums sample = aov_records[s * pixels + slot];
        add_sample_aovs(&aovs, sample.albedo.xyz, sample.normal.xyz, sample.emission.xyz, value, sum);
#endif
        sum += (float4)(value, 1.0f);
    }
    accumulator[slot] = sum;
#if AOVS
    aov_sums[slot] = aovs;
#endif
}
