// The gather of splatting (splat.h): one work-item per pixel of the target tile (params->splat)
// adds the records of the pass's samples (params->frame.w of them) of the traced pixels
// (params->tile) within `reach` pixels, weighted by the filter, to its sums: xyz sum of w L,
// w sum of w.
#include "portability.h"
#include "types.h"
#include "splat.h"

// The filter at offset t, linear between the values `table` holds at |t| = i / scale, i = 0 ..
// SPLAT_TABLE_STEPS (clrender/splatting.py; the last is 0, at the radius): a gaussian's exp per
// neighbour and sample cost 8x the rest of the gather on PoCL.
float splat_weight(__constant const float* table, float scale, float t) {
    float x = fabs(t) * scale;
    int i = (int)x;
    return i < SPLAT_TABLE_STEPS ? mix(table[i], table[i + 1], x - (float)i) : 0.0f;
}

KERNEL void gather_splats(__constant RenderParams* params, __constant const float* table, float scale, int reach,
                          __global const float4* records, __global float4* filtered) {
    int tx = get_global_id(0), ty = get_global_id(1);
    int4 target = params->splat, traced = params->tile;
    if (tx >= target.z || ty >= target.w) return;
    int x = target.x + tx, y = target.y + ty;
    int traced_pixels = traced.z * traced.w;
    float4 sum = filtered[ty * target.z + tx];
    // Loops of the same length in every work-item (neighbours outside the traced pixels, i.e.
    // outside the image, weigh 0): the implementations vectorise them across work-items.
    for (int s = 0; s < params->frame.w; ++s) {
        for (int dy = -reach; dy <= reach; ++dy) {
            int qy = y + dy;
            bool row = qy >= traced.y && qy < traced.y + traced.w;
            __global const float4* records_row = records + s * traced_pixels + (clamp(qy, traced.y, traced.y + traced.w - 1) - traced.y) * traced.z;
            for (int dx = -reach; dx <= reach; ++dx) {
                int qx = x + dx;
                bool inside = row && qx >= traced.x && qx < traced.x + traced.z;
                float4 record = records_row[clamp(qx, traced.x, traced.x + traced.z - 1) - traced.x];
                float2 position = splat_position(record);
                // Offsets from this pixel's centre, small integers first (exact whatever the image size).
                float w = splat_weight(table, scale, (float)(-dx) + (0.5f - position.x)) *
                          splat_weight(table, scale, (float)(-dy) + (0.5f - position.y));
                w = inside ? w : 0.0f;
                sum += (float4)(record.xyz * w, w);
            }
        }
    }
    filtered[ty * target.z + tx] = sum;
}
