// Homogeneous media: analytic transmittance and free-flight sampling with a hero channel.
// With chromatic coefficients, distances are drawn from one channel's exponential (the hero,
// picked uniformly) and weighted by the average of the three channels' pdfs: single-sample
// spectral MIS with the balance heuristic (as pbrt-v4's volpath and Mitsuba's volpathmis), which
// keeps every channel unbiased without fireflies. With spectral MIS off, the hero's own pdf is
// used: unbiased only where every channel has sigma_t > 0, and noisy when they differ (kept as
// the baseline of tools/report_media.py).
#ifndef CLRENDER_HOMOGENEOUS_H
#define CLRENDER_HOMOGENEOUS_H

typedef struct {
    float t;          // distance of the scattering event, or t_max when the segment was passed
    bool scattered;
    float3 weight;    // throughput factor: Tr sigma_s / pdf at a scatter, Tr / P(pass) otherwise
} MediumEvent;

float3 medium_sigma_t(__global const Medium* m) { return m->sigma_a.xyz + m->sigma_s.xyz; }

float medium_g(__global const Medium* m) { return m->params.x; }

// exp(-sigma_t t) per channel; a channel with sigma_t = 0 is 1 even at t = INFINITY (0 * inf is NaN).
float3 transmittance(float3 sigma_t, float t) {
    float3 tau = sigma_t * t;
    return (float3)(sigma_t.x > 0.0f ? exp(-tau.x) : 1.0f, sigma_t.y > 0.0f ? exp(-tau.y) : 1.0f,
                    sigma_t.z > 0.0f ? exp(-tau.z) : 1.0f);
}

float channel(float3 v, int c) { return c == 0 ? v.x : (c == 1 ? v.y : v.z); }

float mean3(float3 v) { return (v.x + v.y + v.z) * (1.0f / 3.0f); }

MediumEvent sample_medium_event(__global const Medium* m, float t_max, bool spectral_mis, Rng* rng) {
    float3 sigma_t = medium_sigma_t(m);
    int hero = min((int)(rng_float(rng) * 3.0f), 2);
    float u = rng_float(rng);
    float sigma_hero = channel(sigma_t, hero);
    MediumEvent event;
    event.t = sigma_hero > 0.0f ? -log(1.0f - u) / sigma_hero : INFINITY;
    event.scattered = event.t < t_max;
    if (!event.scattered) event.t = t_max;
    float3 tr = transmittance(sigma_t, event.t);
    // Distance pdf per channel: sigma_t Tr at a scatter, Tr (the probability to pass) otherwise.
    float3 pdfs = event.scattered ? sigma_t * tr : tr;
    float pdf = spectral_mis ? mean3(pdfs) : channel(pdfs, hero);
    float3 f = event.scattered ? m->sigma_s.xyz * tr : tr;
    // pdf underflows only where Tr does (e.g. sigma_t = 1e4 over a long segment): no energy left.
    event.weight = pdf > 0.0f ? f / pdf : (float3)(0.0f);
    return event;
}

#endif
