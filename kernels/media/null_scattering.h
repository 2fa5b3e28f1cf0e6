// The null-scattering path integral (Miller, Georgiev and Jarosz 2019, "A null-scattering path
// integral formulation of light transport", ACM TOG 38(4)): unbiased free-flight sampling and
// transmittance in heterogeneous media, with path pdfs that MIS can use. docs/heterogeneous-media.md
// derives everything below; in short:
//
// The medium is padded with fictitious "null" particles, sigma_n = sigma_maj - sigma_t >= 0, so
// that the total sigma_maj (a majorant, media/majorant.h) is piecewise constant along a ray. A
// path is then a sequence of vertices of three kinds: absorption (sigma_a), real scattering
// (sigma_s) and null scattering (sigma_n, the direction does not change), joined by majorant
// transmittance T_maj = exp(-integral sigma_maj). Its contribution, per colour channel c, is
//     f_c = prod over vertices of (sigma_kind,c T_maj,c) * (surface, phase and emission terms).
// Two techniques sample such paths:
//   - unidirectional (delta tracking): distances from sigma_maj of the hero channel h, then the
//     vertex kind with probabilities sigma_a,h / sigma_maj,h, sigma_s,h / .., sigma_n,h / ..:
//     p_u,c = prod (sigma_kind,c T_maj,c) (as the pdf of channel c were it the hero);
//   - light (next-event estimation with ratio tracking): the direction from the light sampler,
//     and null vertices only, distances from a residual majorant sigma_r = sigma_maj - sigma_min
//     (residual ratio tracking, Novak et al. 2014: the known minimum density is a control variate)
//     so p_l,c = prod (sigma_r,c exp(-integral sigma_r,c)) over the null vertices.
// With f_c = p_u,c for the unidirectional part, an estimator only needs ratios of pdfs.
//
// Spectral MIS: the hero channel is drawn uniformly per chain of segments (from one scattering
// vertex, or the camera, to the next non-null vertex, through index-matched boundaries), so the
// chain's pdf is the mixture p = mean_c p_c (one-sample MIS with the balance heuristic over
// channels; Miller et al.'s "spectral MIS"). Between the two techniques the power heuristic is
// applied to these mixture pdfs, like everywhere else in path.h ("spectral + NEE MIS").
//
// Every quantity is kept relative to the hero: ratio vectors prod (sigma_c / sigma_hero) and
// optical depths per channel, so nothing overflows and transmittance needs no exp per
// collision: delta tracking costs one log per tentative collision, ratio tracking one log per
// tentative collision and no exp; the exps come once per chain end.
#ifndef CLRENDER_NULL_SCATTERING_H
#define CLRENDER_NULL_SCATTERING_H

// A runaway guard: tentative collisions allowed per chain (delta tracking) or per shadow ray
// (ratio tracking). Reaching it ends the path (or zeroes the shadow ray): a bias, but only where
// the majorant is more than ~4096 times the density along one ray, which tight block majorants
// prevent (a dense cloud scatters long before: scattering probability is density / majorant).
#define NULL_MAX_COLLISIONS 4096

// Ratio tracking roulette: once the hero's transmittance estimate drops below this, each
// further collision survives with probability 1/2 (and the estimate is doubled): unbiased, and
// the work through thick media stays bounded.
#define RATIO_ROULETTE_THRESHOLD 0.1f

// Ratio vectors are renormalised by powers of two outside [2^-32, 2^32]; the exponent goes to a
// separate log so that products of thousands of collisions stay representable.
#define RATIO_RESCALE_HIGH 4294967296.0f
#define RATIO_RESCALE_LOW 2.3283064e-10f
#define LN2_F 0.69314718f

// Events of delta tracking along one medium segment.
#define NULL_PASSED 0
#define NULL_SCATTERED 1
#define NULL_ABSORBED 2

// Optical depth sigma * dt per channel, 0 where sigma is 0 (even for dt = INFINITY: an escaping
// ray through a transparent channel).
float3 optical_depth(float3 sigma, float dt) {
    return (float3)(sigma.x > 0.0f ? sigma.x * dt : 0.0f, sigma.y > 0.0f ? sigma.y * dt : 0.0f,
                    sigma.z > 0.0f ? sigma.z * dt : 0.0f);
}

// Keep a ratio vector's largest component within [2^-32, 2^32] (exactly, by a power of two).
void rescale_ratio(float3* ratio, float* log_scale) {
    float top = max_component(*ratio);
    if (top > RATIO_RESCALE_HIGH || (top < RATIO_RESCALE_LOW && top > 0.0f)) {
        int e;
        frexp(top, &e);
        *ratio = ldexp(*ratio, -e);
        *log_scale += (float)e * LN2_F;
    }
}

// Safe exp(x) for the final weights: no overflow to inf (inf / inf would be NaN).
float3 exp_clamped(float3 x) { return exp(fmin(x, (float3)(80.0f))); }

// ----- unidirectional: delta tracking along a chain -------------------------------------------
typedef struct {
    int hero;          // channel whose majorant and event probabilities drive the sampling
    bool touched;      // some medium segment was tracked (else every weight below is 1)
    int collisions;    // tentative collisions so far (bounded by NULL_MAX_COLLISIONS)
    float3 u_ratio;    // prod sigma_kind,c / sigma_kind,h over the chain's vertices: p_u,c / p_u,h
                       // without the majorant transmittance
    float3 l_ratio;    // prod sigma_r,c / sigma_n,h over the null vertices: p_l,c / p_u,h without
                       // transmittances (the light technique's pdf of the same vertices)
    float u_log, l_log;  // logs of the factors that rescale_ratio took out
    float3 tau_maj;    // integral of sigma_maj,c along the chain
    float3 tau_res;    // integral of sigma_r,c = (d_max - d_min) sigma_t,c along the chain
} NullChain;

void chain_begin(NullChain* c, Rng* rng) {
    c->hero = min((int)(rng_float(rng) * 3.0f), 2);
    c->touched = false;
    c->collisions = 0;
    c->u_ratio = c->l_ratio = (float3)(1.0f);
    c->u_log = c->l_log = 0.0f;
    c->tau_maj = c->tau_res = (float3)(0.0f);
}

// Delta tracking through one medium from origin over [0, t_max) (Woodcock tracking; the
// unidirectional technique above). Returns NULL_PASSED, NULL_SCATTERED (at *t_event) or
// NULL_ABSORBED, and accumulates the chain's ratios. Media emit nothing, so an absorption
// simply ends the path.
int delta_track(const Scene* scene, int medium, float3 origin, float3 dir, float t_max,
                NullChain* c, Rng* rng, float* t_event) {
    __global const Medium* m = scene->media + medium;
    float3 sigma_a = m->sigma_a.xyz, sigma_s = m->sigma_s.xyz, sigma_t = sigma_a + sigma_s;
    int h = c->hero;
    float sigma_t_h = channel(sigma_t, h);
    c->touched = true;
    MajorantIterator it = majorant_iterator(scene, m, origin, dir, t_max);
    MajorantSegment seg;
    while (majorant_next(scene, m, &it, &seg)) {
        float3 sigma_maj = seg.d_max * sigma_t;
        float3 sigma_r = (seg.d_max - seg.d_min) * sigma_t;
        float maj_h = seg.d_max * sigma_t_h;
        float t = seg.t0;
        while (true) {
            // Tentative collision: exponential distance against the hero's majorant.
            float dt = maj_h > 0.0f ? -log(1.0f - rng_float(rng)) / maj_h : INFINITY;
            if (!(t + dt < seg.t1)) {  // passes the rest of the segment
                c->tau_maj += optical_depth(sigma_maj, seg.t1 - t);
                c->tau_res += optical_depth(sigma_r, seg.t1 - t);
                break;
            }
            t += dt;
            c->tau_maj += optical_depth(sigma_maj, dt);
            c->tau_res += optical_depth(sigma_r, dt);
            if (++c->collisions > NULL_MAX_COLLISIONS) return NULL_ABSORBED;
            float density = majorant_ray_density(scene, m, &it, t);
            float3 s_a = density * sigma_a, s_s = density * sigma_s;
            float3 s_n = fmax(sigma_maj - s_a - s_s, (float3)(0.0f));
            // The vertex kind, with the hero's probabilities sigma_kind,h / sigma_maj,h.
            float u = rng_float(rng) * maj_h;
            float a_h = channel(s_a, h), s_h = channel(s_s, h), n_h = channel(s_n, h);
            if (u < a_h) return NULL_ABSORBED;
            if (u < a_h + s_h) {
                c->u_ratio *= s_s / s_h;
                rescale_ratio(&c->u_ratio, &c->u_log);
                *t_event = t;
                return NULL_SCATTERED;
            }
            if (n_h > 0.0f) {  // a null vertex: the path goes on unchanged
                c->u_ratio *= s_n / n_h;
                c->l_ratio *= sigma_r / n_h;
                rescale_ratio(&c->u_ratio, &c->u_log);
                rescale_ratio(&c->l_ratio, &c->l_log);
            }
        }
    }
    return NULL_PASSED;
}

// Throughput factor at the end of a chain (a scattering vertex, a surface or an escape):
// f_c / p, with p the mixture mean_c p_u,c (spectral MIS) or the hero's p_u,h alone. Since
// f_c = p_u,c this is p_u,c / p = u_ratio_c T_maj,c / mean(u_ratio T_maj).
float3 chain_weight(const NullChain* c, bool spectral_mis) {
    if (!c->touched) return (float3)(1.0f);
    float reference = min3(c->tau_maj);
    float3 p = c->u_ratio * exp(-(c->tau_maj - reference));
    float denominator = spectral_mis ? mean3(p) : channel(p, c->hero);
    return denominator > 0.0f ? p / denominator : (float3)(0.0f);
}

// Ratio of the chain's transmittance pdfs, unidirectional over light technique (mixtures or
// hero): the directional pdfs of the two techniques are multiplied by these parts, so a
// power heuristic on (pdf_dir * ratio, pdf_light) is the heuristic on the full path pdfs.
// Clamped to [1e-12, 1e12]: beyond, one technique has all the weight anyway.
float chain_pdf_ratio(const NullChain* c, bool spectral_mis) {
    if (!c->touched) return 1.0f;
    float reference = min3(c->tau_res);   // tau_res <= tau_maj per channel: exponents <= 0
    float3 pu = c->u_ratio * exp(-(c->tau_maj - reference));
    float3 pl = c->l_ratio * exp(-(c->tau_res - reference));
    float mu = spectral_mis ? mean3(pu) : channel(pu, c->hero);
    float ml = spectral_mis ? mean3(pl) : channel(pl, c->hero);
    float ratio = mu / ml * exp(clamp(c->u_log - c->l_log, -80.0f, 80.0f));
    return ml > 0.0f ? clamp(ratio, 1e-12f, 1e12f) : 1e12f;
}

// ----- light technique: residual ratio tracking along a shadow ray ---------------------------
typedef struct {
    int hero;
    int collisions;
    float3 t_ratio;    // prod sigma_n,c / sigma_r,h over the null vertices
    float3 l_ratio;    // prod sigma_r,c / sigma_r,h over the null vertices: p_l,c / p_l,h
    float t_log, l_log;
    float3 tau_maj;    // integral of sigma_maj,c
    float3 tau_res;    // integral of sigma_r,c
    float hero_estimate;  // the hero's running product (<= 1: sigma_n <= sigma_r), times roulette
    float roulette;    // product of 1 / survival probabilities
} RatioTracker;

RatioTracker ratio_tracker(Rng* rng) {
    RatioTracker r;
    r.hero = min((int)(rng_float(rng) * 3.0f), 2);
    r.collisions = 0;
    r.t_ratio = r.l_ratio = (float3)(1.0f);
    r.t_log = r.l_log = 0.0f;
    r.tau_maj = r.tau_res = (float3)(0.0f);
    r.hero_estimate = 1.0f;
    r.roulette = 1.0f;
    return r;
}

// Track one medium of a shadow ray over [0, t_max). Returns false when the estimate became 0
// (roulette, or the runaway guard). Where a segment's majorant equals its minorant (every
// homogeneous medium, constant blocks of a grid) there is no tentative collision at all: the
// control variate exp(-sigma_min t) is the exact transmittance.
bool ratio_track(const Scene* scene, int medium, float3 origin, float3 dir, float t_max,
                 RatioTracker* r, Rng* rng) {
    __global const Medium* m = scene->media + medium;
    float3 sigma_t = m->sigma_a.xyz + m->sigma_s.xyz;
    float sigma_t_h = channel(sigma_t, r->hero);
    MajorantIterator it = majorant_iterator(scene, m, origin, dir, t_max);
    MajorantSegment seg;
    while (majorant_next(scene, m, &it, &seg)) {
        float3 sigma_maj = seg.d_max * sigma_t;
        float3 sigma_r = (seg.d_max - seg.d_min) * sigma_t;
        float r_h = (seg.d_max - seg.d_min) * sigma_t_h;
        float t = seg.t0;
        while (true) {
            float dt = r_h > 0.0f ? -log(1.0f - rng_float(rng)) / r_h : INFINITY;
            if (!(t + dt < seg.t1)) {
                r->tau_maj += optical_depth(sigma_maj, seg.t1 - t);
                r->tau_res += optical_depth(sigma_r, seg.t1 - t);
                break;
            }
            t += dt;
            r->tau_maj += optical_depth(sigma_maj, dt);
            r->tau_res += optical_depth(sigma_r, dt);
            if (++r->collisions > NULL_MAX_COLLISIONS) return false;
            float density = majorant_ray_density(scene, m, &it, t);
            float3 s_n = fmax(sigma_maj - density * sigma_t, (float3)(0.0f));
            r->t_ratio *= s_n / r_h;
            r->l_ratio *= sigma_r / r_h;
            rescale_ratio(&r->t_ratio, &r->t_log);
            rescale_ratio(&r->l_ratio, &r->l_log);
            r->hero_estimate *= channel(s_n, r->hero) / r_h;
            if (r->hero_estimate < RATIO_ROULETTE_THRESHOLD) {
                if (rng_float(rng) >= 0.5f) return false;
                r->hero_estimate *= 2.0f;
                r->roulette *= 2.0f;
            }
        }
    }
    return true;
}

// The transmittance estimate of a tracked shadow ray, with spectral MIS over the hero:
//     T_c = f_c / p_l,h = t_ratio_c exp(-(tau_maj,c - tau_res,h)),  returned as T_c / mean_c(p_l,c / p_l,h)
// (or T_c alone without spectral MIS), times the roulette factor. *pdf_ratio receives the ratio
// of the transmittance pdfs, unidirectional over light technique, for the same path: since
// p_u,c carries exactly f_c's transmittance factors, it is mean(T) / mean(p_l / p_l,h). The
// caller multiplies the directional (BSDF or phase) pdf by it in the power heuristic.
float3 ratio_transmittance(const RatioTracker* r, bool spectral_mis, float* pdf_ratio) {
    float reference = min3(r->tau_res);
    float3 pl = r->l_ratio * exp(-(r->tau_res - reference));
    float ml = spectral_mis ? mean3(pl) : channel(pl, r->hero);
    if (!(ml > 0.0f)) {
        *pdf_ratio = 0.0f;
        return (float3)(0.0f);
    }
    float3 tr = r->t_ratio * exp_clamped(r->t_log - r->l_log - (r->tau_maj - reference)) / ml;
    *pdf_ratio = spectral_mis ? mean3(tr) : channel(tr, r->hero);
    return tr * r->roulette;
}

// ----- the path tracer's view: one medium segment of a chain --------------------------------
// An event in the form path.h uses for every medium (media/homogeneous.h): at a real
// scattering the weight closes the chain (f / p); passing leaves the chain open (weight 1,
// the chain's weight is applied where it ends); absorption ends the path (weight 0).
MediumEvent null_scattering_event(const Scene* scene, int medium, Ray ray, float t_max,
                                  NullChain* chain, bool spectral_mis, Rng* rng) {
    MediumEvent event;
    event.t = t_max;
    int kind = delta_track(scene, medium, ray.origin, ray.direction, t_max, chain, rng, &event.t);
    event.scattered = kind == NULL_SCATTERED;
    event.weight = kind == NULL_ABSORBED ? (float3)(0.0f)
                   : (event.scattered ? chain_weight(chain, spectral_mis) : (float3)(1.0f));
    return event;
}

#endif
