// The null-scattering path integral for grid media (GRID_MEDIA == VOLUME_NULL; Miller, Georgiev
// and Jarosz 2019, "A null-scattering path integral formulation of light transport", ACM TOG
// 38(4)): unbiased free-flight sampling and transmittance, with path pdfs that MIS can use.
// docs/heterogeneous-media.md derives everything below; in short:
//
// The medium is padded with fictitious "null" particles, sigma_n = sigma_maj - sigma_t >= 0, so
// that the total sigma_maj (a majorant, media/majorant.h) is piecewise constant along a ray. A
// path is then a sequence of vertices of three kinds: absorption (sigma_a), real scattering
// (sigma_s) and null scattering (sigma_n, the direction does not change), joined by majorant
// transmittance T_maj = exp(-integral sigma_maj). Its contribution, per colour channel c, is
//     f_c = prod over vertices of (sigma_kind,c T_maj,c) * (surface, phase and emission terms).
// Two techniques sample such paths:
//   - unidirectional (delta tracking): distances from sigma_maj of the hero channel h, then a
//     real (sigma_t,h / sigma_maj,h) or null (sigma_n,h / ..) vertex; a real one scatters, its
//     albedo sigma_s / sigma_t a weight (absorption is not sampled as a vertex):
//     p_u,c = prod (sigma_kind,c T_maj,c), kind t or n (as the pdf of channel c were it the hero);
//   - light (next-event estimation with ratio tracking): the direction from the light sampler,
//     and null vertices only, distances from a residual majorant sigma_r = sigma_maj - sigma_min
//     (residual ratio tracking, Novak et al. 2014: the known minimum density is a control variate)
//     so p_l,c = prod (sigma_r,c exp(-integral sigma_r,c)) over the null vertices.
// With f_c = albedo_c p_u,c for the unidirectional part, an estimator only needs ratios of pdfs.
//
// Spectral MIS: the hero channel is drawn uniformly per segment (one medium between two
// surfaces or a surface and a scattering vertex), whose pdf is then the mixture
// p = mean_c p_c (one-sample MIS with the balance heuristic over channels; Miller et al.'s
// "spectral MIS"); the path's pdf is the product of its segments' mixtures. Between the two
// techniques the power heuristic is applied to these mixture pdfs ("spectral + NEE MIS"): each
// segment contributes the ratio mean_c p_u,c / mean_c p_l,c to the MIS weights of path.h.
//
// Every quantity is kept relative to the hero: ratio vectors prod (sigma_c / sigma_hero) and
// optical depths per channel, so nothing overflows and transmittance needs no exp per
// collision: delta tracking costs one log per tentative collision, ratio tracking one log per
// tentative collision and no exp; the exps come once per segment. The collision loop is
// media/tracking.h.
#ifndef CLRENDER_NULL_SCATTERING_H
#define CLRENDER_NULL_SCATTERING_H
#include "math.h"
#include "rng.h"
#include "camera.h"
#include "media/medium_sample.h"
#include "media/medium_record.h"
#include "media/tracking.h"
#if GRID_MEDIA == VOLUME_NULL

// Ratio tracking roulette: once the hero's transmittance estimate drops below this, each
// further collision survives with probability 1/2 (and the estimate is doubled): unbiased, and
// the work through thick media stays bounded.
#define RATIO_ROULETTE_THRESHOLD 0.1f

// Ratio vectors are renormalised by powers of two outside [2^-32, 2^32]; the exponent goes to a
// separate log so that products of thousands of collisions stay representable.
#define RATIO_RESCALE_HIGH 4294967296.0f
#define RATIO_RESCALE_LOW 2.3283064e-10f

// A product of per-channel ratios, kept as ratio * exp(log_scale).
typedef struct {
    float3 ratio;
    float log_scale;
} RatioProduct;

RatioProduct ratio_one(void) {
    RatioProduct r;
    r.ratio = (float3)(1.0f);
    r.log_scale = 0.0f;
    return r;
}

// Multiply by a factor, keeping the largest component within [2^-32, 2^32] (exactly, by a
// power of two).
void ratio_mul(RatioProduct* r, float3 factor) {
    r->ratio *= factor;
    float top = max_component(r->ratio);
    if (top > RATIO_RESCALE_HIGH || (top < RATIO_RESCALE_LOW && top > 0.0f)) {
        int e;
        frexp(top, &e);
        r->ratio = ldexp(r->ratio, -e);
        r->log_scale += (float)e * LN2_F;
    }
}

// The per-channel pdfs of a technique up to a common factor: ratio * exp(-(tau - reference)).
float3 relative_pdfs(RatioProduct r, float3 tau, float reference) {
    return r.ratio * exp(-(tau - reference));
}

// Ratio of the mixture pdfs of the two techniques, mean(p_u) / mean(p_l), given relative pdfs
// and the logs of their scales. Clamped to [1e-12, 1e12]: beyond, one technique has all the
// weight anyway.
float mixture_pdf_ratio(float3 pu, float log_u, float3 pl, float log_l) {
    float mu = mean3(pu), ml = mean3(pl);
    if (!(ml > 0.0f)) return 1e12f;
    return clamp(mu / ml * exp(clamp(log_u - log_l, -80.0f, 80.0f)), 1e-12f, 1e12f);
}

// ----- unidirectional: delta tracking -------------------------------------------------------
// One segment of a path ray through a grid medium over [0, t_max): scattered (weight f / p of
// the segment's vertices) or passed (weight f / p and the pdf ratio for MIS); absorbed (weight 0)
// only where the walk gave up (exhausted). A real collision (probability sigma_t,h / sigma_maj,h)
// always scatters, its albedo sigma_s / sigma_t a weight per channel, as the homogeneous media
// and Mitsuba's volpath do: absorption drawn as an event with the hero's probabilities ended the
// paths of a channel of high albedo wherever the hero's was low (a cloud of albedo (0.99, 0.5,
// 0.5): 2.7x the red channel's variance). *collisions: tentative collisions (for the tests).
MediumSample delta_tracking_sample(const Scene* scene, __global const Medium* m, Ray ray, float t_max,
                                   bool spectral_mis, Rng* rng, int* collisions) {
    int h = sample_hero(rng);
    RatioProduct u_ratio = ratio_one();   // prod sigma_kind,c / sigma_kind,h: p_u,c / p_u,h
    RatioProduct l_ratio = ratio_one();   // prod sigma_r,c / sigma_n,h over the null vertices
    float3 albedo = (float3)(1.0f);   // sigma_s / sigma_t at the scattering vertex
    MediumSample s;
    s.event = MEDIUM_EVENT_PASS;
    s.t = t_max;
    s.pdf_ratio = 1.0f;
    CollisionWalk w = collision_walk(scene, m, ray.origin, ray.direction, t_max, h, false);
    while (next_collision(scene, m, &w, rng)) {
        float3 sigma_maj = walk_sigma_maj(&w);
        float3 s_a, s_s;
        grid_coefficients(scene, m, majorant_ray_voxel(&w.blocks, w.t), w.density, &s_a, &s_s);
        float3 s_n = fmax(sigma_maj - s_a - s_s, (float3)(0.0f));
        // Real or null, with the hero's probabilities sigma_t,h / sigma_maj,h and sigma_n,h / ..
        float u = rng_float(rng) * channel(sigma_maj, h);
        float3 s_t = s_a + s_s;
        float t_h = channel(s_t, h), n_h = channel(s_n, h);
        if (u < t_h) {
            ratio_mul(&u_ratio, s_t / t_h);
            albedo = select((float3)(0.0f), s_s / s_t, s_t > 0.0f);
            s.event = MEDIUM_EVENT_SCATTER;
            s.t = w.t;
            break;
        }
        if (n_h > 0.0f) {  // a null vertex: the path goes on unchanged
            ratio_mul(&u_ratio, s_n / n_h);
            ratio_mul(&l_ratio, walk_sigma_res(&w) / n_h);
        }
    }
    *collisions = w.collisions;
    if (w.exhausted) s.event = MEDIUM_EVENT_ABSORB;
    if (s.event == MEDIUM_EVENT_ABSORB) {
        s.weight = (float3)(0.0f);
        return s;
    }
    // f_c = albedo_c p_u,c: the weight is that over the mixture of the p_u (or the hero's p_u,h
    // without spectral MIS), p_u,c / p_u,h = u_ratio_c T_maj,c / T_maj,h.
    float3 pu = relative_pdfs(u_ratio, w.tau_maj, min_component(w.tau_maj));
    float denominator = spectral_mis ? mean3(pu) : channel(pu, h);
    s.weight = denominator > 0.0f ? albedo * pu / denominator : (float3)(0.0f);
    if (s.event == MEDIUM_EVENT_PASS) {
        float reference = min_component(w.tau_res);   // tau_res <= tau_maj per channel: exponents <= 0
        s.pdf_ratio = mixture_pdf_ratio(relative_pdfs(u_ratio, w.tau_maj, reference), u_ratio.log_scale,
                                        relative_pdfs(l_ratio, w.tau_res, reference), l_ratio.log_scale);
    }
    return s;
}

// ----- light technique: residual ratio tracking ---------------------------------------------
// Transmittance of a shadow segment through a grid medium over [0, t_max), with spectral MIS
// over the hero:
//     T_c = f_c / p_l,h = t_ratio_c exp(-(tau_maj,c - tau_res,h)), returned as T_c / mean_c(p_l,c / p_l,h)
// (or T_c alone without spectral MIS), times the roulette factor. *pdf_ratio: mean(p_u) / mean(p_l)
// for the same vertices; since p_u,c is exactly f_c it is mean(f) / mean(p_l). Where a segment's
// majorant equals its minorant (constant blocks) there is no tentative collision at all: the
// control variate exp(-sigma_min t) is the exact transmittance.
float3 ratio_tracking_transmittance(const Scene* scene, __global const Medium* m, float3 origin,
                                    float3 dir, float t_max, bool spectral_mis, Rng* rng,
                                    float* pdf_ratio, int* collisions) {
    int h = sample_hero(rng);
    RatioProduct t_ratio = ratio_one();   // prod sigma_n,c / sigma_r,h over the null vertices
    RatioProduct l_ratio = ratio_one();   // prod sigma_r,c / sigma_r,h: p_l,c / p_l,h
    float hero_estimate = 1.0f;  // the hero's running product (<= 1: sigma_n <= sigma_r), times roulette
    float roulette = 1.0f;       // product of 1 / survival probabilities
    bool alive = true;
    *pdf_ratio = 1.0f;
    CollisionWalk w = collision_walk(scene, m, origin, dir, t_max, h, true);
    while (alive && next_collision(scene, m, &w, rng)) {
        float3 sigma_r = walk_sigma_res(&w);
        float r_h = channel(sigma_r, h);
        float3 s_n = fmax(walk_sigma_maj(&w) - w.density * w.sigma_t, (float3)(0.0f));
        ratio_mul(&t_ratio, s_n / r_h);
        ratio_mul(&l_ratio, sigma_r / r_h);
        hero_estimate *= channel(s_n, h) / r_h;
        if (hero_estimate < RATIO_ROULETTE_THRESHOLD) {
            alive = rng_float(rng) < 0.5f;
            hero_estimate *= 2.0f;
            roulette *= 2.0f;
        }
    }
    *collisions = w.collisions;
    if (!alive || w.exhausted) return (float3)(0.0f);
    float reference = min_component(w.tau_res);
    float3 pl = relative_pdfs(l_ratio, w.tau_res, reference);
    float ml = spectral_mis ? mean3(pl) : channel(pl, h);
    if (!(ml > 0.0f)) return (float3)(0.0f);
    float3 f = t_ratio.ratio * exp(fmin(t_ratio.log_scale - l_ratio.log_scale - (w.tau_maj - reference), 80.0f));
    *pdf_ratio = mixture_pdf_ratio(f, 0.0f, pl, 0.0f);
    return f / ml * roulette;
}

// ----- the interface media/medium.h dispatches to -------------------------------------------
MediumSample sample_grid_medium(const Scene* scene, __global const Medium* m, Ray ray, float t_max,
                                Rng* rng) {
    int collisions;
    return delta_tracking_sample(scene, m, ray, t_max, media_spectral_mis(scene), rng, &collisions);
}

float3 grid_transmittance(const Scene* scene, __global const Medium* m, float3 origin, float3 dir,
                          float t_max, Rng* rng, float* pdf_ratio) {
    int collisions;
    return ratio_tracking_transmittance(scene, m, origin, dir, t_max, media_spectral_mis(scene), rng,
                                        pdf_ratio, &collisions);
}

bool grid_scatters_once(const Scene* scene) { return false; }

#endif
#endif
