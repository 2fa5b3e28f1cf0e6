// Pixel reconstruction filters: their values (which splatting weighs samples by, splat.h) and
// filter importance sampling (render.filter_method "importance"): each camera sample's image
// position is drawn from its pixel's filter, so the mean of a pixel's samples is the filtered
// image and a sample counts in its own pixel only. RenderParams.filter, built by
// clrender/filters.py (which also evaluates the filters on the host, for tests).
//
// Mitsuba's filters are separable, f(tx) f(ty); each axis transforms one of the camera sample's
// two numbers, monotonically, so the stratification of a Sobol point (one sampler dimension)
// carries over to the filtered positions. Mitsuba's gaussian has no closed-form inverse CDF (an
// inverse erf, missing from OpenCL C, or Newton's method on erf would cost a dozen exp and erf
// calls per sample, 40% of a Cornell-box path on PoCL), so each axis draws from a distribution
// close to f whose inverse CDF is cheap, and the sample carries the weight f / q, both
// normalised: exact in expectation for any such q. The map is the filter's exact inverse CDF,
// tabulated: with c the uniform number folded into the lower half, v = sqrt(2c) (on which the
// exact offset depends smoothly even at the radius, where f starts linearly from 0 and c
// quadratically), and the offset a cubic Hermite interpolation in v of the exact offset and its
// derivative, in FILTER_CELLS cells (one float4 of coefficients each: no search, one load). At
// 64 cells the weights of Mitsuba's gaussian vary by 2e-8 (variance), so regions of one colour
// stay as noiseless as with the box; a tent's offset is linear in v, its weights are 1 up to
// rounding.
//
// At the image's edges Mitsuba samples inside the film only and divides by the filter weights a
// pixel received: its filter is truncated to the image. So is ours: a pixel k whole pixels from
// an edge draws from f restricted to offsets beyond -(k + 0.5) on that side, from the host's
// tables of both distributions at those FILTER_EDGES offsets (the filters are symmetric).
#ifndef CLRENDER_FILTER_H
#define CLRENDER_FILTER_H
#include "lanes.h"
#include "math.h"
#include "types.h"

// The filter at offset t (pixels), as Mitsuba's eval: gaussian exp(-t^2 / (2 stddev^2)) less its
// value at the radius, tent 1 - |t| / radius, both 0 beyond the radius.
lane_float filter_value(__constant Filter* filter, lane_float t) {
    if (filter->kind.x == PIXEL_FILTER_GAUSSIAN) return fmax(exp_fast(filter->shape.x * t * t) - filter->shape.y, 0.0f);
    return fmax(1.0f - fabs(t) * filter->shape.x, 0.0f);
}

// The filter at the offsets t, t + 1, t + 2, ..., one value per filter_row_next. The gaussian by
// a recurrence, exp(a (t + 1)^2) = exp(a t^2) exp(a (2t + 1)), the step's factor itself
// multiplied by exp(2a) each time: three exps for a row instead of one per value (a splat
// record's 2 (2 reach + 1) values cost 6 % of ppg-torus's render on PoCL); within a few ulps of
// filter_value.
typedef struct {
    lane_float t, g, step, growth;   // the next offset; the gaussian's exp(a t^2) and factors
} FilterRow;

FilterRow filter_row(__constant Filter* filter, lane_float t) {
    FilterRow row = {t, 0.0f, 0.0f, 0.0f};
    if (filter->kind.x == PIXEL_FILTER_GAUSSIAN) {
        float a = filter->shape.x;
        row.g = exp_fast(a * t * t);
        row.step = exp_fast(a * (2.0f * t + 1.0f));
        row.growth = exp_fast((lane_float)(2.0f * a));
    }
    return row;
}

lane_float filter_row_next(__constant Filter* filter, FilterRow* row) {
    lane_float value;
    if (filter->kind.x == PIXEL_FILTER_GAUSSIAN) {
        value = fmax(row->g - filter->shape.y, 0.0f);
        row->g *= row->step;
        row->step *= row->growth;
    } else {
        value = filter_value(filter, row->t);
    }
    row->t += 1.0f;
    return value;
}

// An offset from the centre of pixel `pixel` (of `size` along this axis), from u in [0, 1), and
// *weight: f / q of it, normalised over the part of the filter inside the image.
lane_float sample_filter_axis(__constant Filter* filter, lane_float u, lane_int pixel, int size, lane_float* weight) {
    __constant const float* edge_cdf = (__constant const float*)filter->edge_cdf;
    __constant const float* edge_mass = (__constant const float*)filter->edge_mass;
    // The distributions' values where the image truncates them (0 and 1 where it does not).
    // Clamped to the tables also for the lanes of a packet beyond the image (packets of 8
    // overhang a tile whose width is no multiple of 8), which trace nothing. (Integer clamp and
    // min with vector bounds: Oclgrind gets the vector-and-scalar forms wrong.)
    lane_int last = (lane_int)(FILTER_EDGES - 1);
    lane_int to_low = clamp(pixel, (lane_int)(0), last), to_high = clamp(size - 1 - pixel, (lane_int)(0), last);
    lane_float q_low = LANE_LOAD(edge_cdf, to_low, ), q_high = 1.0f - LANE_LOAD(edge_cdf, to_high, );
    lane_float f_low = LANE_LOAD(edge_mass, to_low, ), f_high = 1.0f - LANE_LOAD(edge_mass, to_high, );
    lane_float c = q_low + u * (q_high - q_low);
    lane_int upper = c > 0.5f;   // the offset's sign: the map covers the lower half
    lane_float v = sqrt(2.0f * select(c, 1.0f - c, upper));
    lane_float x = v * (float)FILTER_CELLS;
    lane_int cell = min(lane_float_to_int(x), (lane_int)(FILTER_CELLS - 1));
    lane_float s = x - lane_int_to_float(cell);
    lane_float a = LANE_LOAD(filter->cells, cell, .x), b = LANE_LOAD(filter->cells, cell, .y);
    lane_float cc = LANE_LOAD(filter->cells, cell, .z), d = LANE_LOAD(filter->cells, cell, .w);
    lane_float t = a + s * (b + s * (cc + s * d));
    // f / q = f_normalised dt/dc, with dt/dc = dt/dv / v; at v = 0 its limit, 1 (the map's
    // slope there is the exact one, 1 / sqrt(f_normalised'(-radius))).
    lane_float dt_dc = (b + s * (2.0f * cc + 3.0f * s * d)) * (float)FILTER_CELLS / v;
    lane_float ratio = select((lane_float)(1.0f), filter_value(filter, t) * filter->support.y * dt_dc, v > 0.0f);
    *weight = ratio * ((q_high - q_low) / (f_high - f_low));
    return select(t, -t, upper);
}

// The image position of a camera sample of pixel (x, y), relative to the pixel's top-left
// corner, from the sampler's u, and *weight (1 for the box).
lane_float2 sample_filter(__constant Filter* filter, lane_float2 u, lane_int x, int y, int width, int height,
                          lane_float* weight) {
    if (filter->kind.x == PIXEL_FILTER_BOX) {
        *weight = 1.0f;
        return u;
    }
    lane_float weight_x, weight_y;
    lane_float tx = sample_filter_axis(filter, u.x, x, width, &weight_x);
    lane_float ty = sample_filter_axis(filter, u.y, (lane_int)(y), height, &weight_y);
    *weight = weight_x * weight_y;
    return make_lane_float2(0.5f + tx, 0.5f + ty);
}

#endif
