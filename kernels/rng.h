// Counter-based random numbers: every number is a hash of (pixel, sample index, seed, draw
// counter), so images do not depend on the device, work-group size or how samples are split
// into launches.
#ifndef CLRENDER_RNG_H
#define CLRENDER_RNG_H

typedef struct { uint key; uint counter; } Rng;

// "lowbias32" integer hash (C. Wellons, 2018): full avalanche with two multiplies.
uint hash_u32(uint x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

Rng rng_for_sample(uint pixel, uint sample, uint seed) {
    Rng rng;
    rng.key = hash_u32(pixel ^ hash_u32(sample ^ hash_u32(seed ^ 0x5bd1e995u)));
    rng.counter = 0u;
    return rng;
}

// Uniform in [0, 1): 24 random mantissa bits, so 1.0f is never returned.
float rng_float(Rng* rng) {
    uint bits = hash_u32(rng->key + rng->counter * 0x9e3779b9u);
    rng->counter += 1u;
    return (float)(bits >> 8) * 0x1.0p-24f;
}

float2 rng_float2(Rng* rng) {
    float a = rng_float(rng);
    return (float2)(a, rng_float(rng));
}

#endif
