// The record every material's sampler returns; bsdf.h dispatches over material kinds.
#ifndef CLRENDER_BSDF_SAMPLE_H
#define CLRENDER_BSDF_SAMPLE_H

typedef struct {
    float3 wi;
    float3 weight;   // f * |cos| / pdf_w (for a delta lobe: its weight / its discrete probability)
    float pdf_w;     // 0: no sample (the path ends); for a delta lobe the lobe's probability
    float eta;       // n(wi side) / n(wo side) when the sample crosses an interface, else 1
    bool delta;
} BsdfSample;

BsdfSample bsdf_sample_none(void) {
    BsdfSample bs;
    bs.wi = (float3)(0.0f, 0.0f, 1.0f);
    bs.weight = (float3)(0.0f);
    bs.pdf_w = 0.0f;
    bs.eta = 1.0f;
    bs.delta = false;
    return bs;
}

#endif
