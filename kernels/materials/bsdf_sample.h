// The record every material's sampler returns; bsdf.h dispatches over material kinds.
#ifndef CLRENDER_BSDF_SAMPLE_H
#define CLRENDER_BSDF_SAMPLE_H
#include "lanes.h"

// Per lane (lanes.h).
typedef struct {
    lane_float3 wi;
    lane_float3 weight;   // f * |cos| / pdf_w (for a delta lobe: its weight / its discrete probability)
    lane_float pdf_w;     // 0: no sample (the path ends); for a delta lobe the lobe's probability
    lane_float eta;       // n(wi side) / n(wo side) when the sample crosses an interface, else 1
    lane_int delta;       // a comparison's result (LANE_TRUE / 0)
} BsdfSample;

BsdfSample bsdf_sample_none(void) {
    BsdfSample bs;
    bs.wi = make_lane_float3((lane_float)(0.0f), (lane_float)(0.0f), (lane_float)(1.0f));
    bs.weight = l3_splat(0.0f);
    bs.pdf_w = 0.0f;
    bs.eta = 1.0f;
    bs.delta = 0;
    return bs;
}

#endif
