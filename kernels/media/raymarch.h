// Ray marching through grid media (GRID_MEDIA == VOLUME_RAYMARCH): a biased preview, the
// piecewise-constant approximation of the density along each ray (docs/heterogeneous-media.md).
//
// A ray is cut into steps inside the non-empty majorant blocks (media/majorant.h; empty blocks
// are skipped). The density is taken at one jittered point of each step (one jitter fraction
// per ray: a stratified, unbiased estimate of the density integral D) and held constant over
// the step, so within a step the medium is homogeneous and everything of media/homogeneous.h
// applies exactly, in units of density x length instead of length:
//   - free flight: the hero's collision depth D* ~ Exp(sigma_t,h) is drawn once and the march
//     stops in the step where D crosses it; the collision lies inside that step where its
//     constant density puts it (the step's optical depth places it, not a uniform point).
//     Weights and pdf ratios are those of a homogeneous medium at depth D: spectral MIS,
//     albedo-weighted collisions, and light sampling once per scattering vertex (path.h).
//   - transmittance of shadow rays: exp(-sigma_t D), marched with the same steps, with Russian
//     roulette once it is small (2x coarser shadow steps were tried: they carried most of
//     marching's bias for 5-10% of speed, docs/performance.md).
// The bias is Jensen's: E[exp(-sigma D)] >= exp(-sigma E[D]), of the order of the variance of D's
// estimate, which shrinks with the step. Step length, per majorant block: `step` (RenderParams
// .volume.x) times the smaller of one voxel (measured along the ray) and MARCH_STEP_OPTICAL_DEPTH
// of the block's majorant optical depth, so steps are fine where the medium is dense and coarse
// where it is thin, and the same in voxels and optical depths at any scene scale.
#ifndef CLRENDER_RAYMARCH_H
#define CLRENDER_RAYMARCH_H
#include "math.h"
#include "rng.h"
#include "camera.h"
#include "media/medium_sample.h"
#include "media/medium_record.h"
#include "media/homogeneous.h"
#include "media/majorant.h"
#if GRID_MEDIA == VOLUME_RAYMARCH

// MARCH_STEP_OPTICAL_DEPTH (the majorant optical depth of a step at step 1, see the top) and
// MARCH_MAX_STEPS_PER_VOXEL come from clrender/layout.py, which also reports the media where the
// latter binds: the refinement by optical depth stops at that many steps per voxel (times
// 1 / step), i.e. only where a voxel holds more than 32 optical depths of majorant and the
// medium is opaque within a fraction of a voxel.
// Shadow rays play Russian roulette whenever their weighted transmittance drops below this.
#define MARCH_ROULETTE_BELOW 0.1f
// Marching stops once every channel's transmittance is below exp(-11.5) = 1e-5.
#define MARCH_MAX_OPTICAL_DEPTH 11.5f

float march_step(const Scene* scene) { return scene->params->volume.x; }

bool march_single_scattering(const Scene* scene) { return scene->params->volume.y == 0.0f; }

// Steps of one ray through one grid medium, pulled one at a time (like the majorant walk).
typedef struct {
    MajorantIterator blocks;
    MajorantSegment seg;
    float step;          // in voxels (and in units of MARCH_STEP_OPTICAL_DEPTH)
    float voxel_length;  // world length of one voxel along the ray
    float sigma_max;     // the largest channel of sigma_t per unit density
    float jitter;        // where in each step the density is taken, as a fraction
    int index, count;    // the next step of the current majorant segment, and its step count
    float t, dt;         // the current step [t, t + dt)
    float density;       // the density taken for it
} Marcher;

Marcher marcher(const Scene* scene, __global const Medium* m, float3 origin, float3 dir, float t_max,
                float step, float jitter) {
    Marcher mr;
    mr.blocks = majorant_iterator(scene, m, origin, dir, t_max);
    mr.step = step;
    mr.voxel_length = 1.0f / length(mr.blocks.voxel_dir);
    mr.sigma_max = max_component(medium_sigma_t(m));
    mr.jitter = jitter;
    mr.index = mr.count = 0;
    mr.t = mr.dt = mr.density = 0.0f;
    return mr;
}

// Advance to the next step; false when the ray has left the medium. A majorant segment is cut
// into equal steps no longer than the step length of its block.
bool march_next(const Scene* scene, __global const Medium* m, Marcher* mr) {
    while (mr->index >= mr->count) {
        if (!majorant_next(scene, m, &mr->blocks, &mr->seg)) return false;
        float by_depth = MARCH_STEP_OPTICAL_DEPTH / (mr->seg.d_max * mr->sigma_max);
        float longest = mr->step * fmax(mr->voxel_length / MARCH_MAX_STEPS_PER_VOXEL,
                                        fmin(mr->voxel_length, by_depth));
        float span = mr->seg.t1 - mr->seg.t0;
        mr->count = (int)fmin(ceil(span / longest), 1e9f);
        mr->dt = span / (float)mr->count;
        mr->index = 0;
    }
    mr->t = mr->seg.t0 + (float)mr->index * mr->dt;
    mr->density = majorant_ray_density(scene, m, &mr->blocks, mr->t + mr->jitter * mr->dt);
    ++mr->index;
    return true;
}

// Density integral beyond which every channel with sigma_t > 0 has T < 1e-5 (0 when none has).
float march_depth_limit(float3 sigma_t) {
    float3 positive = select((float3)(INFINITY), sigma_t, sigma_t > 0.0f);
    return MARCH_MAX_OPTICAL_DEPTH / min_component(positive);
}

// ----- the interface media/medium.h dispatches to -------------------------------------------
MediumSample sample_grid_medium(const Scene* scene, __global const Medium* m, Ray ray, float t_max,
                                Rng* rng) {
    float3 sigma_t = medium_sigma_t(m), sigma_s = medium_sigma_s(m);
    bool spectral_mis = media_spectral_mis(scene);
    int hero = sample_hero(rng);
    float target = sample_free_flight(sigma_t, hero, rng_float(rng));   // D*
    float limit = march_depth_limit(sigma_t);
    Marcher mr = marcher(scene, m, ray.origin, ray.direction, t_max, march_step(scene), rng_float(rng));
    float depth = 0.0f;
    while (depth < limit && march_next(scene, m, &mr)) {
        float step_depth = mr.density * mr.dt;
        if (depth + step_depth > target) {
            float t = mr.t + (target - depth) / mr.density;
            float3 sigma_a;   // per unit density, where the albedo grid (if any) is read
            grid_coefficients(scene, m, majorant_ray_voxel(&mr.blocks, t), 1.0f, &sigma_a, &sigma_s);
            MediumSample s = free_flight_sample(sigma_t, sigma_s, target, true, hero, spectral_mis);
            s.t = t;
            return s;
        }
        depth += step_depth;
    }
    MediumSample s = free_flight_sample(sigma_t, sigma_s, depth, false, hero, spectral_mis);
    s.t = t_max;
    return s;
}

float3 grid_transmittance(const Scene* scene, __global const Medium* m, float3 origin, float3 dir,
                          float t_max, Rng* rng, float* pdf_ratio) {
    float3 sigma_t = medium_sigma_t(m);
    float limit = march_depth_limit(sigma_t);
    Marcher mr = marcher(scene, m, origin, dir, t_max, march_step(scene), rng_float(rng));
    // Russian roulette, as ratio tracking's: whenever the weighted estimate of the thinnest
    // channel drops below 0.1 (every ln 2 of optical depth beyond 2.3), the ray survives with
    // probability 1/2 and its weight doubles: unbiased for the marched medium, and the march
    // through a thick cloud ends after a few steps instead of at T = 1e-5.
    float depth = 0.0f, weight = 1.0f;
    float sigma_min = min_component(sigma_t);
    float roulette_depth = -log(MARCH_ROULETTE_BELOW) / sigma_min;   // exp(-sigma_min depth) = 0.1
    while (depth < limit && march_next(scene, m, &mr)) {
        depth += mr.density * mr.dt;
        while (depth > roulette_depth) {
            if (rng_float(rng) >= 0.5f) return (float3)(0.0f);
            weight *= 2.0f;
            roulette_depth += LN2_F / sigma_min;
        }
    }
    float3 tr = transmittance(sigma_t, depth);
    *pdf_ratio = mean3(tr);
    return tr * weight;
}

bool grid_scatters_once(const Scene* scene) { return march_single_scattering(scene); }

#endif
#endif
