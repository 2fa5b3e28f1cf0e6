// Mitsuba's direct integrator (direct.h) for LANES camera samples at once, in the packets'
// lane types (path_packets.h: the same materials, lights and environment; features.py gives it
// no masks, whose crossing differs between the two integrators). Every lane draws the numbers
// direct.h's sample draws: a lane that would not draw a number gives it back.
#ifndef CLRENDER_DIRECT_PACKETS_H
#define CLRENDER_DIRECT_PACKETS_H
#include "lanes.h"
#include "rng.h"
#include "camera.h"
#include "scene.h"
#include "environment.h"
#include "materials/material.h"
#include "materials/textured_params.h"
#include "path_packets.h"
#include "direct_samples.h"

// Give back the numbers of one draw (rng_float2, or rng_float where `single`) in `lanes`.
void rng_give_back(Rng* rng, lane_int lanes, bool single) {
    uint taken = single || rng->sampler == SAMPLER_SOBOL ? 1u : 2u;
    rng->counter -= select((lane_uint)(0u), (lane_uint)(taken), lanes);
}

// The emission one BSDF sample from the lanes' surface points finds, MIS-weighted against
// n_light light samples (direct.h, direct_bsdf_sample).
lane_float3 direct_bsdf_samples(const Scene* scene, const SurfacePoint* sp, const SurfaceLanes* surface,
                                lane_float3 wo, lane_int lanes, int n_light, int n_bsdf, Rng* rng) {
    // direct.h's sample_bsdf: a lobe number where a smooth, rough or plastic lobe takes one,
    // then the direction's 2D draw.
    lane_int lobes = surface->smooth | surface->glossy.rough | surface->glossy.plastic;
    lane_float u_lobe = rng_float(rng);
    rng_give_back(rng, !lobes, true);
    BsdfSample bs = sample_bsdf_lanes(scene, sp, surface->color, wo, surface->smooth, surface->conductor,
                                      &surface->glossy, u_lobe, rng_float2(rng), lanes);
    lanes &= (bs.pdf_w > 0.0f) & !is_black(bs.weight);
    if (!lane_any(lanes)) return l3_splat(0.0f);
    // The power heuristic is scale-invariant: the pdf times n_b / n_l weighs the counts; without
    // light samples the BSDF sample has the whole weight, as a delta one.
    lane_int alone = n_light == 0 ? LANE_TRUE : bs.delta;
    lane_float pdf_w = select(bs.pdf_w * ((float)n_bsdf / (float)n_light), (lane_float)(0.0f), alone);
    LaneHit hit;
    lane_int found = closest_hits(scene, spawn_ray_origin(sp, bs.wi), bs.wi, INFINITY, lanes, &hit);
    lane_float3 le = l3_splat(0.0f);
#if ENVIRONMENT != ENVIRONMENT_NONE
    lane_int escaped = lanes & !found;
    if (lane_any(escaped)) le = l3_select(le, escaped_radiance(scene, bs.wi, pdf_w, alone), escaped);
#endif
    if (lane_any(found)) {
        SurfacePoint light = surface_point(scene, &hit, bs.wi);
        le = l3_select(le, emitted_radiance_lanes(scene, &light, sp->p, bs.wi, pdf_w, alone), found);
    }
    return l3_select(l3_splat(0.0f), l3_mul(bs.weight, le), lanes);
}

// The radiance of the lanes' camera samples (0 in lanes not `alive` at the start), as direct.h's
// trace_direct estimates it; with AOVS, *aov receives their sample-level AOVs.
lane_float3 trace_direct_lanes(const Scene* scene, Ray ray, lane_int alive, Rng* rng, AovLanes* aov) {
    int n_light = scene->params->sampling.y, n_bsdf = scene->params->sampling.z;
    lane_float3 radiance = l3_splat(0.0f);
    LaneHit hit;
    lane_int escaped = alive;
    alive = closest_camera_hits(scene, ray.origin, ray.direction, alive, &hit);
#if ENVIRONMENT != ENVIRONMENT_NONE
    escaped &= !alive;
    if (lane_any(escaped)) {
        bool visible = (scene->params->environment.w & HIDE_ENVIRONMENT) == 0;
        aov_record_escapes(scene, aov, ray.direction, l3_splat(1.0f), (lane_float)(1.0f), visible, escaped);
        if (visible)
            radiance = l3_select(radiance, escaped_radiance(scene, ray.direction, (lane_float)(0.0f), LANE_TRUE), escaped);
    }
#endif
    if (!lane_any(alive)) return radiance;
    SurfacePoint sp = surface_point(scene, &hit, ray.direction);
    lane_float3 wo = l3_neg(ray.direction);
    SurfaceLanes surface = surface_lanes(scene, &hit, &sp, wo, alive);
    lane_int smooth = surface.smooth;
    aov_record_surfaces(scene, aov, &sp, surface.color, l3_splat(1.0f), (lane_float)(1.0f), alive & !smooth);
    radiance = l3_select(radiance, emitted_radiance_lanes(scene, &sp, ray.origin, ray.direction, (lane_float)(0.0f), LANE_TRUE),
                         alive);
    // Light samples at the non-delta surfaces (the delta ones draw none: they give them back).
    lane_int lit = alive & !smooth;
    if (n_light > 0 && lane_any(lit)) {
        lane_float3 sum = l3_splat(0.0f);
        for (int i = 0; i < n_light; ++i) {
            lane_float2 u = rng_float2(rng);
            rng_give_back(rng, !lit, false);
            sum = l3_add(sum, direct_light_lanes(scene, &sp, surface.color, &surface.glossy, wo, u, lit,
                                                 (float)n_bsdf / (float)n_light, true));
        }
        radiance = l3_select(radiance, l3_add(radiance, l3_div(sum, (lane_float)((float)n_light))), lit);
    }
    if (n_bsdf > 0 && emission_can_be_hit(scene)) {
        lane_float3 sum = l3_splat(0.0f);
        lane_int scattering = alive & !surface.black_back;   // (a black back scatters nothing: bsdf.h)
        for (int i = 0; i < n_bsdf; ++i)
            sum = l3_add(sum, direct_bsdf_samples(scene, &sp, &surface, wo, scattering, n_light, n_bsdf, rng));
        radiance = l3_select(radiance, l3_add(radiance, l3_div(sum, (lane_float)((float)n_bsdf))), alive);
    }
    return radiance;
}

#endif
