// The gather of splatting (splat.h): one work-item per pixel of the target tile (params->splat)
// adds the records of the pass's samples (params->frame.w of them) of the traced pixels
// (params->tile) within `reach` pixels, weighted by the filter, to its sums: xyz sum of w L,
// w sum of w.
#include "portability.h"
#include "types.h"
#include "filter.h"
#include "splat.h"

KERNEL void gather_splats(__constant RenderParams* params, __constant Filter* filter, int reach,
                          __global const float4* records, __global float4* filtered) {
    int tx = get_global_id(0), ty = get_global_id(1);
    int4 target = params->splat, traced = params->tile;
    if (tx >= target.z || ty >= target.w) return;
    int x = target.x + tx, y = target.y + ty;
    // The traced pixels hold every pixel of the image within `reach` of the target tile.
    int x0 = max(x - reach, traced.x), x1 = min(x + reach, traced.x + traced.z - 1);
    int y0 = max(y - reach, traced.y), y1 = min(y + reach, traced.y + traced.w - 1);
    int traced_pixels = traced.z * traced.w;
    float4 sum = filtered[ty * target.z + tx];
    for (int s = 0; s < params->frame.w; ++s) {
        for (int qy = y0; qy <= y1; ++qy) {
            __global const float4* row = records + s * traced_pixels + (qy - traced.y) * traced.z - traced.x;
            for (int qx = x0; qx <= x1; ++qx) {
                float4 record = row[qx];
                float2 position = splat_position(record);
                // Offsets from this pixel's centre, small integers first (exact whatever the image size).
                float w = filter_value(filter, (float)(x - qx) + (0.5f - position.x)) *
                          filter_value(filter, (float)(y - qy) + (0.5f - position.y));
                sum += (float4)(record.xyz * w, w);
            }
        }
    }
    filtered[ty * target.z + tx] = sum;
}
