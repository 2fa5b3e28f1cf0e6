// Free flight through constant coefficients: homogeneous media, and (measured in density x
// length instead of length) every step of ray marching (media/raymarch.h).
//
// A collision distance is drawn from one channel's exponential (the hero, picked uniformly) and
// weighted by the average of the three channels' pdfs: single-sample spectral MIS with the
// balance heuristic (as pbrt-v4's volpath and Mitsuba's volpathmis), which keeps every channel
// unbiased without fireflies. Collisions are sampled with sigma_t and weighted by the albedo
// (absorption is not an event): f_c = sigma_s,c T_c against p_c = sigma_t,c T_c at a collision,
// f_c = p_c = T_c for passing. With spectral MIS off the hero's own pdf is used: unbiased only
// where every channel has sigma_t > 0, and noisy when they differ (the baseline of
// tools/report_media.py).
//
// For MIS the light technique reaches through such a segment deterministically (probability 1,
// the analytic transmittance), the unidirectional one with the probability of passing, the
// mixture mean_c T_c: that is the pdf ratio of a pass, on both sides (media/transport.h).
#ifndef CLRENDER_HOMOGENEOUS_H
#define CLRENDER_HOMOGENEOUS_H
#include "math.h"
#include "rng.h"
#include "media/medium_sample.h"
#include "media/medium_record.h"

// exp(-sigma_t depth) per channel; a channel with sigma_t = 0 is 1 even at depth = INFINITY
// (0 * inf is NaN).
float3 transmittance(float3 sigma_t, float depth) {
    float3 tau = select((float3)(0.0f), sigma_t * depth, sigma_t > 0.0f);
    return exp(-tau);
}

int sample_hero(Rng* rng) { return min((int)(rng_float(rng) * 3.0f), 2); }

// Depth (length, or density integral) to the hero channel's next collision; INFINITY where that
// channel is transparent.
float sample_free_flight(float3 sigma_t, int hero, float u) {
    float sigma = channel(sigma_t, hero);
    return sigma > 0.0f ? -log(1.0f - u) / sigma : INFINITY;
}

// The sample of a free flight that collided at `depth`, or passed a segment of that depth.
MediumSample free_flight_sample(float3 sigma_t, float3 sigma_s, float depth, bool collided, int hero,
                                bool spectral_mis) {
    float3 tr = transmittance(sigma_t, depth);
    float3 pdfs = collided ? sigma_t * tr : tr;
    float pdf = spectral_mis ? mean3(pdfs) : channel(pdfs, hero);
    float3 f = collided ? sigma_s * tr : tr;
    MediumSample s;
    s.event = collided ? MEDIUM_EVENT_SCATTER : MEDIUM_EVENT_PASS;
    s.t = depth;
    // pdf underflows only where Tr does (e.g. sigma_t = 1e4 over a long segment): no energy left.
    s.weight = pdf > 0.0f ? f / pdf : (float3)(0.0f);
    s.pdf_ratio = collided ? 1.0f : mean3(tr);
    return s;
}

// A free flight whose collision distance is drawn before the segment's end is known (it does not
// depend on it; media/medium.h says why).
typedef struct {
    int hero;
    float t;   // distance to the collision (INFINITY: none, or not drawn yet)
} FreeFlight;

FreeFlight begin_homogeneous_flight(__global const Medium* m, Rng* rng) {
    FreeFlight f;
    f.hero = sample_hero(rng);
    f.t = sample_free_flight(medium_sigma_t(m), f.hero, rng_float(rng));
    return f;
}

// The flight over the segment [0, t_max): collided if its distance falls inside.
MediumSample sample_homogeneous_medium(__global const Medium* m, FreeFlight f, float t_max, bool spectral_mis) {
    bool collided = f.t < t_max;
    return free_flight_sample(medium_sigma_t(m), medium_sigma_s(m), collided ? f.t : t_max, collided, f.hero,
                              spectral_mis);
}

// Analytic transmittance of a shadow segment; *pdf_ratio as for a pass (see the top).
float3 homogeneous_transmittance(__global const Medium* m, float t_max, float* pdf_ratio) {
    float3 tr = transmittance(medium_sigma_t(m), t_max);
    *pdf_ratio = mean3(tr);
    return tr;
}

#endif
