// The one collision loop of the tracking estimators of grid media (delta tracking for free
// flight, residual ratio tracking for transmittance: media/null_scattering.h). pbrt-v4's
// SampleT_maj without the callback, which OpenCL C 1.2 lacks: the caller pulls tentative
// collisions from a walk and decides what each one is.
//
// Along the ray the walk visits the majorant segments (media/majorant.h) and draws collisions
// from an exponential whose rate is the hero channel's sigma_t times a sampling density: the
// segment's majorant d_max (delta tracking) or its residual d_max - d_min (ratio tracking; the
// minimum density is then a control variate: Novak et al. 2014). Between collisions it adds up
// each channel's optical depth of the majorant and of the residual, which the estimators'
// weights and pdfs need whichever density drove the sampling:
//
//     CollisionWalk w = collision_walk(scene, m, origin, dir, t_max, hero, residual);
//     while (next_collision(scene, m, &w, rng)) { ... w.t, w.density, walk_sigma_maj(&w) ... }
//     if (w.exhausted) ...   // stopped by the runaway guard
#ifndef CLRENDER_TRACKING_H
#define CLRENDER_TRACKING_H
#include "rng.h"
#include "media/majorant.h"
#include "media/medium_record.h"

// A runaway guard: tentative collisions allowed per segment. Reaching it is treated as an
// absorption (delta tracking) or a zero estimate (ratio tracking): a bias, but only where the
// majorant is more than ~4096 times the density along one ray, which tight block majorants
// prevent (a dense cloud scatters long before: scattering probability is density / majorant).
#define TRACKING_MAX_COLLISIONS 4096

typedef struct {
    MajorantIterator blocks;
    MajorantSegment seg;  // the current segment (while in_segment)
    bool in_segment;
    bool residual;        // sample against d_max - d_min instead of d_max
    bool exhausted;       // stopped by TRACKING_MAX_COLLISIONS
    int collisions;       // tentative collisions so far
    float3 sigma_t;       // the medium's coefficients per unit density
    int hero;
    float t;              // distance of the current collision
    float density;        // density there
    float3 tau_maj;       // integral of sigma_maj,c = d_max sigma_t,c so far
    float3 tau_res;       // integral of sigma_r,c = (d_max - d_min) sigma_t,c so far
} CollisionWalk;

// Optical depth sigma * dt per channel, 0 where sigma is 0 (even for dt = INFINITY: an escaping
// ray through a transparent channel).
float3 optical_depth(float3 sigma, float dt) {
    return (float3)(sigma.x > 0.0f ? sigma.x * dt : 0.0f, sigma.y > 0.0f ? sigma.y * dt : 0.0f,
                    sigma.z > 0.0f ? sigma.z * dt : 0.0f);
}

CollisionWalk collision_walk(const Scene* scene, __global const Medium* m, float3 origin, float3 dir,
                             float t_max, int hero, bool residual) {
    CollisionWalk w;
    w.blocks = majorant_iterator(scene, m, origin, dir, t_max);
    w.in_segment = false;
    w.residual = residual;
    w.exhausted = false;
    w.collisions = 0;
    w.sigma_t = medium_sigma_t(m);
    w.hero = hero;
    w.t = 0.0f;
    w.density = 0.0f;
    w.tau_maj = w.tau_res = (float3)(0.0f);
    return w;
}

// Coefficients of the current segment: majorant and residual, per channel.
float3 walk_sigma_maj(const CollisionWalk* w) { return w->seg.d_max * w->sigma_t; }
float3 walk_sigma_res(const CollisionWalk* w) { return (w->seg.d_max - w->seg.d_min) * w->sigma_t; }

void walk_advance(CollisionWalk* w, float dt) {
    w->tau_maj += optical_depth(walk_sigma_maj(w), dt);
    w->tau_res += optical_depth(walk_sigma_res(w), dt);
}

// Move to the next tentative collision (one log each); false when the ray has left the medium
// (the optical depths then cover all of it) or the guard stopped the walk. Where the sampling
// density is 0 (the residual of a constant block, a homogeneous stretch) the segment is passed
// without a collision and without a random number.
bool next_collision(const Scene* scene, __global const Medium* m, CollisionWalk* w, Rng* rng) {
    while (true) {
        if (!w->in_segment) {
            if (!majorant_next(scene, m, &w->blocks, &w->seg)) return false;
            w->in_segment = true;
            w->t = w->seg.t0;
        }
        float density = w->residual ? w->seg.d_max - w->seg.d_min : w->seg.d_max;
        float rate = density * channel(w->sigma_t, w->hero);
        float dt = rate > 0.0f ? -log(1.0f - rng_float(rng)) / rate : INFINITY;
        if (!(w->t + dt < w->seg.t1)) {
            walk_advance(w, w->seg.t1 - w->t);
            w->in_segment = false;
            continue;
        }
        w->t += dt;
        walk_advance(w, dt);
        if (++w->collisions > TRACKING_MAX_COLLISIONS) {
            w->exhausted = true;
            return false;
        }
        w->density = majorant_ray_density(scene, m, &w->blocks, w->t);
        return true;
    }
}

#endif
