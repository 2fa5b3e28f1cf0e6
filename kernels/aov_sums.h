// A pixel's sums of the sample-level AOVs (AovSums, layout.AOV_SUMS; aovs.h says what each is),
// one sample added at a time: written once for the render pass's loop (aovs.h) and for the sums
// of sample items' records (splat.cl, sum_samples), so that both give the same bits.
#ifndef CLRENDER_AOV_SUMS_H
#define CLRENDER_AOV_SUMS_H
#include "types.h"

// Adds one sample: its AOVs (weighted as its colour; emission 0 for a sample whose colour was not
// finite, which counts as black), and its colour `value` to the squared deviations (Welford's
// update, exact in order and far less prone to cancellation than a sum of squares); `sum` is the
// pixel's colour sum before this sample (w: its sample count), the same floats the colour
// accumulates.
void add_sample_aovs(AovSums* sums, float3 albedo, float3 normal, float3 emission, float3 value, float4 sum) {
    sums->albedo.xyz += albedo;
    sums->normal.xyz += normal;
    sums->emission.xyz += emission;
    // The deviations from the means before and after, value - sum / n, as (n value - sum) / n:
    // exactly 0 for a pixel whose samples are all equal (and add up exactly) however the device
    // rounds division, where sum / n may differ from value (GPUs divide to 2.5 ulp by default).
    float n = sum.w;
    float3 before = n > 0.0f ? (n * value - sum.xyz) / n : (float3)(0.0f);
    float3 after = ((n + 1.0f) * value - (sum.xyz + value)) / (n + 1.0f);
    sums->colour_m2.xyz += before * after;
}

#endif
