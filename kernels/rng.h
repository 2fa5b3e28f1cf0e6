// Counter-based random numbers: every number depends only on (pixel, sample index, seed, draw
// counter), so images do not depend on the device, work-group size or how samples are split
// into launches or tiles. Two generators share the Rng type:
// - independent (rng_for_sample): each number is a hash of the four, i.i.d. across samples,
//   pixels and draws. Test kernels use it with one sample per work-item.
// - sobol (rng_for_path with SAMPLER_SOBOL): padded, Owen-scrambled Sobol points after Burley,
//   "Practical Hash-based Owen Scrambling" (JCGT 2020). The counter is a dimension: each draw
//   (rng_float or rng_float2) takes the next one. A pixel's samples in dimension d are the 2D
//   Sobol (0,2)-sequence (dimensions 0 and 1), each coordinate Owen-scrambled and the sample
//   index permuted at random within its octave (sobol_shuffled_index), all seeded by
//   hash(pixel, d, seed); the scrambles of different dimensions are independent, so a path's
//   numbers are as independent as with hashing while the samples of one pixel stratify every 2D
//   draw.
#ifndef CLRENDER_RNG_H
#define CLRENDER_RNG_H
#include "lanes.h"
#include "math.h"

// SAMPLER_INDEPENDENT, SAMPLER_SOBOL: clrender/layout.py SAMPLERS.
// index: the sample index (Sobol's). Per lane (lanes.h): the lanes of a work-item draw in step,
// and their counters differ only where a lane's draw takes fewer numbers.
typedef struct { lane_uint key; lane_uint counter; lane_uint index; int sampler; } Rng;

// "lowbias32" integer hash (C. Wellons, 2018): full avalanche with two multiplies.
lane_uint hash_u32(lane_uint x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

// OpenCL C 1.2 has no bit-reversal builtin: swap halves, then quarters, ... (5 steps).
lane_uint reverse_bits(lane_uint x) {
    x = (x << 16) | (x >> 16);
    x = ((x & 0x00ff00ffu) << 8) | ((x >> 8) & 0x00ff00ffu);
    x = ((x & 0x0f0f0f0fu) << 4) | ((x >> 4) & 0x0f0f0f0fu);
    x = ((x & 0x33333333u) << 2) | ((x >> 2) & 0x33333333u);
    x = ((x & 0x55555555u) << 1) | ((x >> 1) & 0x55555555u);
    return x;
}

// The independent generator's stream of one sample.
Rng rng_for_sample(lane_uint pixel, uint sample, uint seed) {
    Rng rng;
    rng.key = hash_u32(pixel ^ hash_u32(sample ^ hash_u32(seed ^ 0x5bd1e995u)));
    rng.counter = 0u;
    rng.index = 0u;   // unused by the independent generator
    rng.sampler = SAMPLER_INDEPENDENT;
    return rng;
}

// The numbers of camera path `sample` of `pixel` from `sampler` (RenderParams.sampling.x, SAMPLER_*).
Rng rng_for_path(lane_uint pixel, uint sample, uint seed, int sampler) {
    if (sampler != SAMPLER_SOBOL) return rng_for_sample(pixel, sample, seed);
    Rng rng;
    rng.key = hash_u32(pixel ^ hash_u32(seed ^ 0x2c1b3c6du));   // not the sample: scrambles are per pixel
    rng.counter = 0u;
    rng.index = sample;
    rng.sampler = SAMPLER_SOBOL;
    return rng;
}

// A random permutation of the bits of x where bit j depends on bits 0..j only, i.e. an Owen
// scramble of the reversed number: the Laine-Karras hash with N. Vegdahl's constants, as
// pbrt-v4's FastOwenScrambler uses.
lane_uint laine_karras_permutation(lane_uint x, lane_uint seed) {
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}

// Nested uniform (Owen) scramble of x read as the binary fraction 0.b31 b30 ... b0.
lane_uint nested_uniform_scramble(lane_uint x, lane_uint seed) {
    return reverse_bits(laine_karras_permutation(reverse_bits(x), seed));
}

// Sobol dimension 1 with its bits reversed (bit r = fraction digit r + 1): the generator matrix
// is Pascal's triangle mod 2, so digit r is the XOR of the index bits k with r a bit-subset of k
// (Lucas), a superset-sum over the five bits of r in five steps instead of a 32-step loop.
lane_uint sobol_dimension1_reversed(lane_uint index) {
    lane_uint x = index;
    x ^= (x >> 1) & 0x55555555u;
    x ^= (x >> 2) & 0x33333333u;
    x ^= (x >> 4) & 0x0f0f0f0fu;
    x ^= (x >> 8) & 0x00ff00ffu;
    x ^= (x >> 16) & 0x0000ffffu;
    return x;
}

lane_float uint_to_unit_float(lane_uint bits) { return lane_uint_to_float(bits >> 8) * 0x1.0p-24f; }

// Sobol dimension 0 is reverse_bits(index), so its Owen scramble is one reversal; likewise
// dimension 1 from its reversed form.
lane_uint owen_sobol0(lane_uint index, lane_uint seed) { return reverse_bits(laine_karras_permutation(index, seed)); }
lane_uint owen_sobol1(lane_uint index, lane_uint seed) {
    return reverse_bits(laine_karras_permutation(sobol_dimension1_reversed(index), seed));
}

// A hash of the stream's key and its counter: the independent generator's number, the Sobol
// generator's seed of the current dimension.
lane_uint hash_of_counter(const Rng* rng) { return hash_u32(rng->key + rng->counter * 0x9e3779b9u); }

// The current dimension's seeds: one hash of (pixel, seed, dimension), then the index
// permutation's seed and the two coordinates' scramble seeds as its products with distinct odd
// constants, rotated (bijections of the hash, so each is as uniform as the hash; a hash apiece
// would sit on the path's dependency chain). The rotation brings a product's high bits, which
// every bit of the hash moves, to the low bits that decide a scramble's first digits: the
// products' own low bits are the hash's (bit 0 of both, so a point's coordinates took the same
// first-digit flip, and sample 0 of every pixel lay in two of the four quadrants).
typedef struct { lane_uint index; lane_uint x; lane_uint y; } SobolSeeds;
SobolSeeds sobol_dimension_seeds(const Rng* rng) {
    lane_uint h = hash_of_counter(rng);
    SobolSeeds seeds = {h, rotate(h * 0x2c1b3c6du, (lane_uint)(16u)), rotate(h * 0x297a2d39u, (lane_uint)(8u))};
    return seeds;
}

// A random permutation of 0 .. mask (mask = 2^k - 1) chosen by `seed`: four rounds of an odd
// multiply (low bits into high) and a xor-shift by about k / 2 (high bits into low), each a
// bijection of k bits. (Kensler's hash, tried first, hardly mixes bits into bit 0 for k <= 5: the
// first halves of two dimensions' octaves then coincided.)
lane_uint permute_bits(lane_uint i, lane_uint mask, lane_uint seed) {
    lane_uint shift = max((lane_uint)(1u), (32u - clz(mask)) >> 1);
    i = ((i ^ seed) * ((seed >> 7) | 1u)) & mask;
    i ^= i >> shift;
    i = ((i + (seed >> 13)) * 0x9e3779b9u) & mask;
    i ^= i >> shift;
    i = ((i ^ (seed >> 19)) * 0x85ebca6bu) & mask;
    i ^= i >> shift;
    i = ((i + (seed >> 25)) * 0xc2b2ae35u) & mask;
    return i ^ (i >> shift);
}

// The sample index of the current dimension: the index permuted at random within its octave
// [2^j, 2^(j+1)) (0 and 1 stay). The first 2^k samples of a pixel are then Sobol's first 2^k
// points in every dimension, a (0,2)-net however many samples the render takes, and which point
// of one dimension goes with which of another is random, as in pbrt-v4's padded Sobol sampler and
// Mitsuba's ldsampler (there over all of a render's samples, which needs their count). A nested
// uniform scramble of the index (Burley 2020), used before, keeps the pairs {2m, 2m + 1} together
// in every dimension: the teapot's variance at 64 spp was 1.36x this one's (docs/performance.md).
lane_uint sobol_shuffled_index(const Rng* rng, lane_uint seed) {
    lane_uint below_octave = ((lane_uint)(0xffffffffu) >> clz(rng->index | 1u)) >> 1;
    return (rng->index & ~below_octave) | permute_bits(rng->index & below_octave, below_octave, seed);
}

// Uniform in [0, 1): 24 random mantissa bits, so 1.0f is never returned.
lane_float rng_float(Rng* rng) {
    lane_uint bits;
    if (rng->sampler == SAMPLER_SOBOL) {
        SobolSeeds seeds = sobol_dimension_seeds(rng);
        bits = owen_sobol0(sobol_shuffled_index(rng, seeds.index), seeds.x);
    } else {
        bits = hash_of_counter(rng);
    }
    rng->counter += 1u;
    return uint_to_unit_float(bits);
}

// Both coordinates of the Sobol dimension `ahead` past the current one, the counter left as it is.
INLINE lane_float2 sobol_float2_ahead(const Rng* rng, uint ahead) {
    Rng at = *rng;
    at.counter += ahead;
    SobolSeeds seeds = sobol_dimension_seeds(&at);
    lane_uint index = sobol_shuffled_index(&at, seeds.index);
    return make_lane_float2(uint_to_unit_float(owen_sobol0(index, seeds.x)), uint_to_unit_float(owen_sobol1(index, seeds.y)));
}

// Sobol: one dimension, both coordinates of its (0,2)-sequence. Independent: two draws.
lane_float2 rng_float2(Rng* rng) {
    if (rng->sampler == SAMPLER_SOBOL) {
        lane_float2 u = sobol_float2_ahead(rng, 0u);
        rng->counter += 1u;
        return u;
    }
    lane_float a = rng_float(rng);
    return make_lane_float2(a, rng_float(rng));
}

// The numbers of one surface vertex of a camera path (path.h and path_packets.h draw them alike):
// three consecutive 2D draws, its light sample, its BSDF sample's direction, and its lobe
// choice (x) and Russian roulette (y). Drawn together because each Sobol draw is a chain of about
// a dozen dependent integer multiplies (hash, index permutation, scrambles) whose result the
// path waits for; three chains side by side overlap (the Cornell boxes' renders x1.05-1.09,
// docs/performance.md).
typedef struct { lane_float2 light, direction, choice; } VertexNumbers;

VertexNumbers draw_vertex_numbers(Rng* rng) {
    VertexNumbers n;
    if (rng->sampler != SAMPLER_SOBOL) {
        n.light = rng_float2(rng);
        n.direction = rng_float2(rng);
        n.choice = rng_float2(rng);
        return n;
    }
    n.light = sobol_float2_ahead(rng, 0u);
    n.direction = sobol_float2_ahead(rng, 1u);
    n.choice = sobol_float2_ahead(rng, 2u);
    rng->counter += 3u;
    return n;
}

#endif
