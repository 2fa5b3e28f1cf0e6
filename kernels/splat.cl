// The gather of splatting (splat.h): one work-item per pixel of the target tile (params->splat)
// adds the records of the pass's samples (params->frame.w of them) of the traced pixels
// (params->tile) within the filter's reach to its sums: xyz sum of w L, w sum of w.
#include "portability.h"
#include "types.h"
#include "splat.h"

KERNEL void gather_splats(__constant RenderParams* params, __global const float* records, __global float4* filtered) {
    int tx = get_global_id(0), ty = get_global_id(1);
    int4 target = params->splat, traced = params->tile;
    if (tx >= target.z || ty >= target.w) return;
    int x = target.x + tx, y = target.y + ty;
    int reach = params->splat_reach.x;
    int pixels = traced.z * traced.w;
    float4 sum = filtered[ty * target.z + tx];
    // Loops of the same length in every work-item (neighbours outside the traced pixels, i.e.
    // outside the image, weigh 0), which the implementations vectorise across work-items.
    for (int s = 0; s < params->frame.w; ++s) {
        __global const float* pass = records + s * SPLAT_COMPONENTS(reach) * pixels;
        for (int dy = -reach; dy <= reach; ++dy) {
            int qy = y + dy;
            bool row = qy >= traced.y && qy < traced.y + traced.w;
            int row_start = (clamp(qy, traced.y, traced.y + traced.w - 1) - traced.y) * traced.z - traced.x;
            // This pixel is -dy rows from the neighbour's, -dx columns.
            __global const float* y_weights = pass + (SPLAT_Y_WEIGHT(reach) + reach - dy) * pixels + row_start;
            for (int dx = -reach; dx <= reach; ++dx) {
                int qx = x + dx;
                int q = clamp(qx, traced.x, traced.x + traced.z - 1);
                bool inside = row && qx == q;
                float w = pass[(SPLAT_X_WEIGHT + reach - dx) * pixels + row_start + q] * y_weights[q];
                w = inside ? w : 0.0f;
                sum += (float4)(pass[row_start + q], pass[pixels + row_start + q], pass[2 * pixels + row_start + q],
                                1.0f) * w;
            }
        }
    }
    filtered[ty * target.z + tx] = sum;
}
