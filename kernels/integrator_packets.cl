// The megakernel in packets (LANES 8, lanes.h; features.py picks it on CPU devices for the scenes
// path_packets.h covers): one work-item traces the camera paths (or with the direct integrator
// the camera samples, direct_packets.h) of 8 adjacent pixels of a row, in step, so the CPU runs
// them in its vector lanes. Otherwise as integrator.cl: samples in index
// order, random numbers keyed by the pixel of the full image, the pixel-centre record written
// by the launch holding sample 0, non-finite samples dropped and counted, with AOVS the
// sample-level AOVs summed beside the colour (aovs.h), with splatting each sample written as a
// record (splat.h). The arguments are integrator.cl's (the host launches either the same way, 8
// times fewer work-items across).
#include "portability.h"
#include "rng.h"
#include "camera.h"
#include "scene.h"
#include "path_packets.h"
#include "direct_packets.h"
#include "aux_buffers.h"
#include "splat.h"
#if LANES != 8
#error "integrator_packets.cl is built with LANES 8"
#endif

KERNEL void render_pass(RENDER_PASS_ARGUMENTS) {
    int first_column = get_global_id(0) * 8, ty = first_row + (int)get_global_id(1);
    int tile_width = params->tile.z;
    if (first_column >= tile_width || ty >= params->tile.w) return;
    int8 tx = first_column + LANE_INDEX;
    int8 in_tile = tx < tile_width;   // the last work-item of a row may overhang the tile
    int8 x = params->tile.x + tx;
    int y = params->tile.y + ty;
    int width = params->frame.x;
    Scene scene = SCENE_OF_RENDER_PASS_ARGUMENTS;
    uint8 pixel = convert_uint8(y * width + x);   // keys the random numbers
    int slot = ty * tile_width + first_column;    // of lane 0 in this tile's buffers
    int lanes = min(8, tile_width - first_column);
    if (params->frame.z == 0) {
        AuxRecord record = aux_record(&scene, x, y);
        float normal[3][8], depth[8];
        int object[8];
        vstore8(record.normal.x, 0, normal[0]);
        vstore8(record.normal.y, 0, normal[1]);
        vstore8(record.normal.z, 0, normal[2]);
        vstore8(record.depth, 0, depth);
        vstore8(record.object, 0, object);
        for (int i = 0; i < lanes; ++i) {
            aux_geometry[slot + i] = (float4)(normal[0][i], normal[1][i], normal[2][i], depth[i]);
            aux_object[slot + i] = object[i];
        }
    }
    float sums[4][8];
    for (int i = 0; i < 8; ++i) {
        float4 sum = i < lanes ? accumulator[slot + i] : (float4)(0.0f);
        sums[0][i] = sum.x; sums[1][i] = sum.y; sums[2][i] = sum.z; sums[3][i] = sum.w;
    }
    float8 sum_r = vload8(0, sums[0]), sum_g = vload8(0, sums[1]), sum_b = vload8(0, sums[2]);
    float8 count = vload8(0, sums[3]);
#if AOVS
    // Per lane: albedo, normal, emission and the colour's squared deviations (xyz each).
    float aov_in[12][8];
    for (int i = 0; i < 8; ++i) {
        AovSums a = i < lanes ? aov_sums[slot + i] : (AovSums){(float4)(0.0f), (float4)(0.0f), (float4)(0.0f), (float4)(0.0f)};
        float4 parts[4] = {a.albedo, a.normal, a.emission, a.colour_m2};
        for (int k = 0; k < 4; ++k) {
            aov_in[3 * k][i] = parts[k].x; aov_in[3 * k + 1][i] = parts[k].y; aov_in[3 * k + 2][i] = parts[k].z;
        }
    }
    lane_float3 albedo_sum = make_lane_float3(vload8(0, aov_in[0]), vload8(0, aov_in[1]), vload8(0, aov_in[2]));
    lane_float3 normal_sum = make_lane_float3(vload8(0, aov_in[3]), vload8(0, aov_in[4]), vload8(0, aov_in[5]));
    lane_float3 emission_sum = make_lane_float3(vload8(0, aov_in[6]), vload8(0, aov_in[7]), vload8(0, aov_in[8]));
    lane_float3 m2 = make_lane_float3(vload8(0, aov_in[9]), vload8(0, aov_in[10]), vload8(0, aov_in[11]));
#endif
    int8 discarded = 0;
    int first = params->frame.z;
    bool splatting = SPLATTING(params);
    // As integrator.cl: pixels traced only to lend their samples report no dropped samples.
    int8 reports = splatting ? IN_SPLAT_TILE(params, x, (int8)(y)) : (int8)(-1);
    for (int s = first; s < first + params->frame.w; ++s) {
        Rng rng = rng_for_path(pixel, (uint)s, (uint)params->config.z, params->sampling.x);
        CameraSample camera = sample_camera(params, x, y, &rng);
        AovLanes aov = {l3_splat(0.0f), l3_splat(0.0f), l3_splat(0.0f), 0};
        lane_float3 radiance = l3_scale(direct_integrator(&scene) ? trace_direct_lanes(&scene, camera.ray, in_tile, &rng, &aov)
                                                                   : trace_paths(&scene, camera.ray, in_tile, &rng, &aov),
                                        camera.weight);
        // A non-finite sample is dropped (counted as black) and reported, never averaged in.
        int8 finite = isfinite(radiance.x) & isfinite(radiance.y) & isfinite(radiance.z);
        discarded -= in_tile & reports & !finite;
        lane_float3 value = l3_select(l3_splat(0.0f), radiance, finite);
        if (splatting) write_splat_records(params, splat_records, s - first, slot, lanes, value, camera.position);
#if AOVS
        // aovs.h, aov_weight and accumulate_aovs: Welford's update from the sums before this sample.
        albedo_sum = l3_add(albedo_sum, l3_scale(aov.albedo, camera.weight));
        normal_sum = l3_add(normal_sum, l3_scale(aov.normal, camera.weight));
        emission_sum = l3_add(emission_sum, l3_select(l3_splat(0.0f), l3_scale(aov.emission, camera.weight), finite));
        lane_float3 sum = make_lane_float3(sum_r, sum_g, sum_b);
        lane_float3 before = l3_select(l3_splat(0.0f), l3_div(l3_sub(l3_scale(value, count), sum), count), count > 0.0f);
        lane_float3 after = l3_div(l3_sub(l3_scale(value, count + 1.0f), l3_add(sum, value)), count + 1.0f);
        m2 = l3_add(m2, l3_mul(before, after));
#endif
        sum_r += value.x;
        sum_g += value.y;
        sum_b += value.z;
        count += 1.0f;
    }
    vstore8(sum_r, 0, sums[0]);
    vstore8(sum_g, 0, sums[1]);
    vstore8(sum_b, 0, sums[2]);
    vstore8(count, 0, sums[3]);
    for (int i = 0; i < lanes; ++i)
        accumulator[slot + i] = (float4)(sums[0][i], sums[1][i], sums[2][i], sums[3][i]);
#if AOVS
    lane_float3 outs[4] = {albedo_sum, normal_sum, emission_sum, m2};
    for (int k = 0; k < 4; ++k) {
        vstore8(outs[k].x, 0, aov_in[3 * k]); vstore8(outs[k].y, 0, aov_in[3 * k + 1]); vstore8(outs[k].z, 0, aov_in[3 * k + 2]);
    }
    for (int i = 0; i < lanes; ++i) {
        AovSums a;
        a.albedo = (float4)(aov_in[0][i], aov_in[1][i], aov_in[2][i], 0.0f);
        a.normal = (float4)(aov_in[3][i], aov_in[4][i], aov_in[5][i], 0.0f);
        a.emission = (float4)(aov_in[6][i], aov_in[7][i], aov_in[8][i], 0.0f);
        a.colour_m2 = (float4)(aov_in[9][i], aov_in[10][i], aov_in[11][i], 0.0f);
        aov_sums[slot + i] = a;
    }
#endif
    int total = discarded.s0 + discarded.s1 + discarded.s2 + discarded.s3 + discarded.s4 + discarded.s5 +
                discarded.s6 + discarded.s7;
    if (total > 0) atomic_add(discarded_samples, total);
}
