// Splatting: each camera sample, taken at a uniform position in its pixel, counts in every pixel
// whose filter reaches it, weighted by the filter there; a pixel's value is the weighted mean of
// those samples (sum of w L over sum of w), as Mitsuba's image block does. Against drawing a
// sample's position from its own pixel's filter (filter.h) a pixel averages the samples of its
// neighbours too: less variance per pixel (by 1 / (4 pi stddev^2) for a gaussian, 4/9 for a
// tent of radius 1, on white noise), the noise of neighbours correlated.
//
// The render pass writes each sample of the traced pixels as a record: its radiance and the
// filter's weights along x and y for the pixels it reaches (the filters are separable), taken
// where the sample is, in its lanes. splat.cl's gather adds a pass's records to the pixels of the
// target tile, each pixel reading its neighbours' records in a fixed order (sample, then row,
// then column), so a pixel's sums are the same however the samples are split into passes and the
// image into tiles. Records are planes of floats, one per component, so neighbouring work-items
// read neighbouring floats.
#ifndef CLRENDER_SPLAT_H
#define CLRENDER_SPLAT_H
#include "lanes.h"
#include "types.h"
#include "filter.h"

// Whether RenderParams asks the render pass for records (splat.z: the target tile's width).
#define SPLATTING(params) ((params)->splat.z > 0)

// Whether pixel (x, y) of the full image is in the target tile: its own sums count there; the
// other traced pixels only lend their samples.
#define IN_SPLAT_TILE(params, column, row) \
    ((column) >= (params)->splat.x && (column) < (params)->splat.x + (params)->splat.z && \
     (row) >= (params)->splat.y && (row) < (params)->splat.y + (params)->splat.w)

// Floats of one record for a filter reaching `reach` pixels beyond the sample's own: radiance,
// then the weights of pixels d = -reach .. reach along x (component SPLAT_X_WEIGHT + reach + d),
// then along y; clrender/splatting.py sizes the buffer from the same count.
#define SPLAT_COMPONENTS(reach) (3 + 2 * (2 * (reach) + 1))
#define SPLAT_X_WEIGHT 3
#define SPLAT_Y_WEIGHT(reach) (3 + 2 * (reach) + 1)

// One component of the lanes' records: `count` consecutive slots from `out`.
void store_splat_lanes(__global float* out, lane_float value, int count) {
#if LANES == 1
    *out = value;
#else
    float values[LANES];
    vstore8(value, 0, values);
    for (int i = 0; i < count; ++i) out[i] = values[i];
#endif
}

// The first component of the record of sample `index` of the pass at `slot` of the traced pixels.
__global float* splat_record(__constant RenderParams* params, __global float* records, int index, int slot) {
    return records + index * SPLAT_COMPONENTS(params->splat_reach.x) * params->tile.z * params->tile.w + slot;
}

// The radiance of the lanes' samples (sample `index` of the pass, `count` lanes from `slot` of the
// traced pixels): a record's first three components, all that sample items (integrator.cl) write
// when the film does not splat.
void write_sample_radiance(__constant RenderParams* params, __global float* records, int index, int slot, int count,
                           lane_float3 radiance) {
    int pixels = params->tile.z * params->tile.w;
    __global float* record = splat_record(params, records, index, slot);
    store_splat_lanes(record, radiance.x, count);
    store_splat_lanes(record + pixels, radiance.y, count);
    store_splat_lanes(record + 2 * pixels, radiance.z, count);
}

// The records of the lanes' samples: radiance, and the filter at the offsets from the centres of
// the pixels d = -reach .. reach away to the sample's `position` in its pixel (filter.h,
// filter_row).
void write_splat_records(__constant RenderParams* params, __global float* records, int index, int slot, int count,
                         lane_float3 radiance, lane_float2 position) {
    int reach = params->splat_reach.x;
    int pixels = params->tile.z * params->tile.w;
    write_sample_radiance(params, records, index, slot, count, radiance);
    __global float* record = splat_record(params, records, index, slot);
    FilterRow x_weights = filter_row(&params->filter, (float)-reach + 0.5f - position.x);
    FilterRow y_weights = filter_row(&params->filter, (float)-reach + 0.5f - position.y);
    for (int i = 0; i <= 2 * reach; ++i) {
        store_splat_lanes(record + (SPLAT_X_WEIGHT + i) * pixels, filter_row_next(&params->filter, &x_weights), count);
        store_splat_lanes(record + (SPLAT_Y_WEIGHT(reach) + i) * pixels, filter_row_next(&params->filter, &y_weights),
                          count);
    }
}

#endif
