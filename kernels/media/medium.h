// The media interface of the integrator: path.h and media/transport.h see nothing else.
//
//   begin_free_flight      the part of a free flight that does not depend on the segment's end:
//                          a homogeneous medium's collision distance, which bounds the
//                          integrator's surface intersection (nothing beyond it matters; Mitsuba's
//                          volpath caps ray.maxt the same way); nothing for grid media
//   sample_medium          free flight along one ray segment inside one medium: the event
//                          (pass, scatter at t, absorb), the throughput factor f / p and, on a
//                          pass, the ratio of the segment's transmittance pdfs (unidirectional
//                          over light technique) that MIS needs
//   medium_transmittance   transmittance of a shadow segment, and the same pdf ratio
//   sample_medium_phase, eval_medium_phase, medium_scatters_once, medium_beyond, medium_albedo
//
// A homogeneous medium is always sampled analytically (media/homogeneous.h). Grid media use the
// one estimator compiled in: GRID_MEDIA picks the implementation of sample_grid_medium,
// grid_transmittance and grid_scatters_once (media/null_scattering.h or media/raymarch.h; each
// compiles to nothing unless selected, and both are included unconditionally because the
// kernel assembler expands every file once, where it is first included).
//
// MIS through media (derived in docs/heterogeneous-media.md): a path's pdf under either
// technique is its directional pdf times, per medium segment, the mixture over hero channels
// of that segment's pdf; every segment samples its own hero. So the power heuristic needs the
// directional pdf of the other technique times the product of the segments' pdf ratios
// P_u / P_l, which sample_medium (for the unidirectional path) and medium_transmittance (for
// the light sample) return, each from the vertices its own technique produced.
#ifndef CLRENDER_MEDIUM_H
#define CLRENDER_MEDIUM_H
#include "scene.h"
#include "camera.h"
#include "media/medium_sample.h"
#include "media/medium_record.h"
#include "media/phase.h"
#include "media/homogeneous.h"
#include "media/null_scattering.h"
#include "media/raymarch.h"
#if MEDIA

// The medium on the far side of the surface from where the ray arrived (-1: none), from the
// packed TriangleInfo.w (clrender/layout.py, pack_media).
int medium_beyond(const SurfacePoint* sp) {
    return sp->front_face ? (sp->media & 0xFFFF) - 1 : (sp->media >> 16) - 1;
}

FreeFlight begin_free_flight(const Scene* scene, int medium, Rng* rng) {
    __global const Medium* m = scene->media + medium;
#if GRID_MEDIA
    if (medium_is_grid(m)) {
        FreeFlight walked;   // the estimator walks the segment in sample_medium
        walked.hero = -1;
        walked.t = INFINITY;
        return walked;
    }
#endif
    return begin_homogeneous_flight(m, rng);
}

// The flight begun over the segment [0, t_max) of the ray (t_max: the surface hit, or INFINITY).
MediumSample sample_medium(const Scene* scene, int medium, FreeFlight flight, Ray ray, float t_max, Rng* rng) {
    __global const Medium* m = scene->media + medium;
#if GRID_MEDIA
    if (medium_is_grid(m)) return sample_grid_medium(scene, m, ray, t_max, rng);
#endif
    return sample_homogeneous_medium(m, flight, t_max, media_spectral_mis(scene));
}

float3 medium_transmittance(const Scene* scene, int medium, float3 origin, float3 dir, float t_max,
                            Rng* rng, float* pdf_ratio) {
    __global const Medium* m = scene->media + medium;
#if GRID_MEDIA
    if (medium_is_grid(m)) return grid_transmittance(scene, m, origin, dir, t_max, rng, pdf_ratio);
#endif
    return homogeneous_transmittance(m, t_max, pdf_ratio);
}

// The single-scattering albedo sigma_s / sigma_t at p (per channel, 0 where sigma_t is 0).
float3 medium_albedo(const Scene* scene, int medium, float3 p) {
    __global const Medium* m = scene->media + medium;
    float3 sigma_a = medium_sigma_a(m), sigma_s = medium_sigma_s(m);
#if GRID_MEDIA
    if (medium_is_grid(m)) grid_coefficients(scene, m, world_to_voxel(m, p), 1.0f, &sigma_a, &sigma_s);
#endif
    float3 sigma_t = sigma_a + sigma_s;
    return (float3)(sigma_t.x > 0.0f ? sigma_s.x / sigma_t.x : 0.0f, sigma_t.y > 0.0f ? sigma_s.y / sigma_t.y : 0.0f,
                    sigma_t.z > 0.0f ? sigma_s.z / sigma_t.z : 0.0f);
}

// Whether a path ends after the light sample at a scattering vertex in this medium (ray
// marching's single-scattering preview); that light sample then has no MIS partner.
bool medium_scatters_once(const Scene* scene, int medium) {
#if GRID_MEDIA
    return medium_is_grid(scene->media + medium) && grid_scatters_once(scene);
#else
    return false;
#endif
}

// The phase function: a direction around `dir` (the incoming travel direction) and its pdf.
float3 sample_medium_phase(const Scene* scene, int medium, float3 dir, float2 u, float* pdf_w) {
    return sample_phase_hg(dir, medium_g(scene->media + medium), u, pdf_w);
}

float eval_medium_phase(const Scene* scene, int medium, float3 dir, float3 wi) {
    return eval_phase_hg(dot(dir, wi), medium_g(scene->media + medium));
}

#endif
#endif
