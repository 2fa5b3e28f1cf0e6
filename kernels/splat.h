// Splatting: each camera sample, taken at a uniform position in its pixel, counts in every pixel
// whose filter reaches it, weighted by the filter there; a pixel's value is the weighted mean of
// those samples (sum of w L over sum of w), as Mitsuba's image block does. Against drawing a
// sample's position from its own pixel's filter (filter.h) a pixel averages the samples of its
// neighbours too: less variance per pixel (by 1 / (4 pi stddev^2) for a gaussian, 4/9 for a
// tent of radius 1, on white noise), the noise of neighbours correlated.
//
// The render pass writes each sample of the traced pixels as a record (radiance, position in its
// pixel); splat.cl's gather adds a pass's records to the pixels of the target tile, each pixel
// reading its neighbours' records in a fixed order (sample, then row, then column), so a pixel's
// sums are the same however the samples are split into passes and the image into tiles.
#ifndef CLRENDER_SPLAT_H
#define CLRENDER_SPLAT_H

// Quantum of a sample's position in its pixel: 1 / 65536 pixel (16 bits a coordinate).
#define SPLAT_POSITION_STEPS 65536.0f

// A sample's radiance and its position in its pixel ([0, 1)^2 from the top-left corner).
float4 splat_record(float3 radiance, float x, float y) {
    uint qx = min((uint)(x * SPLAT_POSITION_STEPS), 65535u), qy = min((uint)(y * SPLAT_POSITION_STEPS), 65535u);
    return (float4)(radiance, as_float(qx | (qy << 16)));
}

// The record's position in its pixel, at the centre of its quantum.
float2 splat_position(float4 record) {
    uint q = as_uint(record.w);
    return (float2)((float)(q & 0xffffu) + 0.5f, (float)(q >> 16) + 0.5f) / SPLAT_POSITION_STEPS;
}

// Whether RenderParams asks the render pass for records (splat.z: the target tile's width).
#define SPLATTING(params) ((params)->splat.z > 0)

// Whether pixel (x, y) of the full image is in the target tile: its own sums count there; the
// other traced pixels only lend their samples.
#define IN_SPLAT_TILE(params, column, row) \
    ((column) >= (params)->splat.x && (column) < (params)->splat.x + (params)->splat.z && \
     (row) >= (params)->splat.y && (row) < (params)->splat.y + (params)->splat.w)

#endif
