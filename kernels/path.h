// Unidirectional path tracing: next-event estimation and BSDF (or phase) sampling combined by MIS
// with the power heuristic; Russian roulette on the throughput after the roulette depth.
// Depth counts scattering vertices after the camera: depth 1 sees emitters directly, so max
// depth 1 renders emission only and max depth 2 direct lighting (the convention of Mitsuba).
// Index-matched boundaries (MATERIAL_INTERFACE: interfaces and index-matched dielectrics) only
// switch the current medium and transmit their colour (the dielectric's tint, else 1); they are
// not path vertices, nor is a mask the path passes through (materials/mask.h). Media are reached
// only through media/medium.h and media/transport.h.
//
// MIS weights use the pdf of the technique that did not produce the sample, measured the same
// way: prev_pdf_w is the directional pdf of the last vertex times the transmittance pdf ratio
// of every medium segment since (media/medium.h), so an emitter reached through a thick medium
// gets the small weight its unidirectional pdf deserves.
#ifndef CLRENDER_PATH_H
#define CLRENDER_PATH_H
#include "math.h"
#include "rng.h"
#include "sampling.h"
#include "camera.h"
#include "scene.h"
#include "lights.h"
#include "materials/material.h"
#include "materials/textured_params.h"
#include "materials/bsdf.h"
#include "materials/mask.h"
#include "materials/shading_maps.h"
#include "materials/toon.h"
#include "media/medium.h"
#include "media/transport.h"
#include "aovs.h"
#include "light_paths.h"

// Emission at a surface hit from the previous vertex prev_p (null boundaries may lie between).
INLINE float3 emitted_radiance(const Scene* scene, const Material* m, const SurfacePoint* sp,
                               float3 prev_p, float3 dir, float prev_pdf_w, bool prev_delta) {
    if (!sp->front_face || sp->emitter < 0) return (float3)(0.0f);
    float3 le = material_emission(m);
    if (prev_delta) return le;
    float light_pdf_w = emitter_selection_pmf(scene, sp->emitter) *
                        area_emitter_pdf_w(scene->emitters, sp->emitter, prev_p, sp->p, -dot(dir, sp->ng));
    return le * power_heuristic(prev_pdf_w, light_pdf_w);
}

// Next-event estimation at a surface point with the light sample drawn by u (rng: the shadow
// ray's numbers in media). bsdf_share scales the BSDF technique's pdf in the MIS weight: 1 for
// one sample of each, n_bsdf / n_light in the direct integrator (direct.h).
INLINE float3 direct_light(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                           int medium, float bsdf_share, float2 u, Rng* rng) {
    LightSample ls = sample_light(scene, sp->p, u);
    if (!(ls.pdf_w > 0.0f) || is_black(ls.radiance)) return (float3)(0.0f);
    float3 f = eval_bsdf(scene, m, sp, wo, ls.wi) * shading_map_factor(m, sp, ls.wi);
    if (is_black(f)) return (float3)(0.0f);
    float3 origin = spawn_ray_origin(sp, ls.wi);
#if MEDIA
    if (!(dot(ls.wi, sp->ng) > 0.0f)) medium = medium_beyond(sp);
#endif
    float pdf_ratio;
    float3 tr = shadow_ray(scene, origin, ls.wi, ls.dist, medium, rng, &pdf_ratio);
    if (is_black(tr)) return (float3)(0.0f);
    float weight = ls.delta ? 1.0f : power_heuristic(ls.pdf_w, sample_bsdf_pdf(scene, m, sp, wo, ls.wi) * pdf_ratio * bsdf_share);
    return f * tr * light_sample_radiance(scene, &ls) * (weight / ls.pdf_w);
}

// Mitsuba's hide_emitters (RenderParams.environment.w & HIDE_EMITTING_SHAPES): camera rays pass
// through emitting shapes, whichever side they hit, as if they were not there; paths that
// scattered before still see them.
bool hidden_from_camera(const Scene* scene, const SurfacePoint* sp) {
    return (scene->params->environment.w & HIDE_EMITTING_SHAPES) != 0 && sp->emitter >= 0;
}

// Russian roulette with the number u: survive with probability equal to the throughput without
// the eta^2 radiance scaling of refraction, capped so that bright paths (e.g. in high-albedo
// media) are never kept forever and weights stay bounded by 1 / 0.95.
bool survive_roulette(float3* throughput, float eta_scale, float u) {
    float survive = fmin(max_component(*throughput) * eta_scale, 0.95f);
    if (u >= survive) return false;
    *throughput /= survive;
    return true;
}

// The radiance of one camera path; with AOVS, *aov receives its first non-delta vertex (aovs.h).
float3 trace_path(const Scene* scene, Ray ray, Rng* rng, AovSample* aov) {
    int max_depth = scene->params->config.x;
    int rr_depth = scene->params->config.y;
    float3 radiance = (float3)(0.0f);
    float3 throughput = (float3)(1.0f);
    float3 prev_p = ray.origin;
    float prev_pdf_w = 0.0f;
    bool prev_delta = true;  // the camera ray sees emitters with full weight
    // Product of eta^2 over the refractions so far: throughput * eta_scale is the throughput
    // without the radiance scaling of refraction (see materials/dielectric.h), which roulette
    // must use, or it would kill paths for being inside glass (pbrt-v4's etaScale).
    float eta_scale = 1.0f;
    int medium = -1;
    int null_crossings = 0;   // index-matched boundaries and hidden emitters passed
#if MEDIA
    medium = scene->params->media.x;
#endif
    CausticEvents events = caustic_events_none();
    int depth = 1;
    while (depth <= max_depth) {
        Hit hit;
        float t_max = INFINITY;
#if MEDIA
        FreeFlight flight;
        if (medium >= 0) {
            flight = begin_free_flight(scene, medium, rng);
            t_max = flight.t;   // a surface beyond the collision does not matter
        }
#endif
        bool found = intersect_scene(scene, ray.origin, ray.direction, t_max, &hit);
#if MEDIA
        if (medium >= 0) {
            MediumSample ms = sample_medium(scene, medium, flight, ray, found ? hit.t : INFINITY, rng);
            if (ms.event == MEDIUM_EVENT_SCATTER)
                aov_record_medium(aov, scene, medium, ray.origin + ms.t * ray.direction, throughput, eta_scale);
            throughput *= ms.weight;
            prev_pdf_w *= ms.pdf_ratio;
            if (ms.event == MEDIUM_EVENT_ABSORB || is_black(throughput)) break;
            if (ms.event == MEDIUM_EVENT_SCATTER) {
                if (depth == max_depth) break;
                float3 p = ray.origin + ms.t * ray.direction;
                bool last = medium_scatters_once(scene, medium);
                // Without a light sample here, phase sampling alone finds the emitters, with full
                // weight (as after a delta lobe); a path that ends here has only its light sample.
                bool light_sample = last || medium_makes_light_samples(scene->media + medium);
                if (light_sample)
                    radiance += throughput * direct_light_in_medium(scene, p, ray.direction, medium, !last, rng);
                if (last) break;
                // The phase function is sampled exactly: phase / pdf = 1 leaves the throughput.
                ray.direction = sample_medium_phase(scene, medium, ray.direction, rng_float2(rng), &prev_pdf_w);
                ray.origin = prev_p = p;
                prev_delta = !light_sample;
                if (depth >= rr_depth && !survive_roulette(&throughput, eta_scale, rng_float(rng))) break;
                ++depth;
                continue;
            }
        }
#endif
        if (!found) {
            aov_record_escape(aov, scene, ray.direction, throughput, eta_scale,
                              depth > 1 || (scene->params->environment.w & HIDE_ENVIRONMENT) == 0);
            // RenderParams.environment.w & HIDE_ENVIRONMENT (render.hide_environment): camera
            // rays that escape, through null boundaries or not, see black; the environment still
            // lights the scene.
            if (depth > 1 || (scene->params->environment.w & HIDE_ENVIRONMENT) == 0)
                radiance += throughput * escaped_radiance(scene, ray.direction, prev_pdf_w, prev_delta);
            break;
        }
        SurfacePoint sp = surface_point(scene, &hit, ray.direction);
        if (depth == 1 && hidden_from_camera(scene, &sp)) {
#if MEDIA
            medium = medium_beyond(&sp);
#endif
            ray.origin = spawn_ray_origin(&sp, ray.direction);
            if (++null_crossings > MAX_NULL_CROSSINGS) break;
            continue;
        }
        Material m = surface_material(scene, &sp);
#if MEDIA
        if (material_is_interface(&m)) {
            throughput *= material_boundary_transmittance(&m);
            medium = medium_beyond(&sp);
            ray.origin = spawn_ray_origin(&sp, ray.direction);
            if (++null_crossings > MAX_NULL_CROSSINGS) break;
            continue;
        }
#endif
        if (!light_paths_take(scene, &events, sp.emitter))
            radiance += throughput * emitted_radiance(scene, &m, &sp, prev_p, ray.direction, prev_pdf_w, prev_delta);
#if TEXTURES
        if (passes_through_mask(&m, rng)) {
            ray.origin = spawn_ray_origin(&sp, ray.direction);
#if MEDIA
            medium = medium_beyond(&sp);
#endif
            if (++null_crossings > MAX_NULL_CROSSINGS) break;
            continue;
        }
        bend_shading_normal(scene, &m, &sp, -ray.direction);
#endif
        if (!material_is_delta(&m)) aov_record_surface(aov, &m, &sp, throughput, eta_scale);
        if (depth == max_depth) break;
        float3 wo = -ray.direction;
#if TOON
        // Any vertex, not only the camera's: a toon surface seen in a mirror, through glass or
        // from a diffuse bounce gives its toon radiance, which already holds its lighting (it
        // counts as direct lighting, hence after the max-depth test), and the path ends.
        if (material_kind(&m) == MATERIAL_TOON) {
            radiance += throughput * eval_toon_radiance(scene, &m, &sp, wo, medium, rng);
            break;
        }
#endif
        // The vertex's numbers (rng.h; a delta vertex leaves its light sample's unused).
        VertexNumbers u = draw_vertex_numbers(rng);
        if (!material_is_delta(&m)) radiance += throughput * direct_light(scene, &m, &sp, wo, medium, 1.0f, u.light, rng);

        BsdfSample bs = sample_bsdf_with(scene, &m, &sp, wo, u.choice.x, u.direction);
        bs.weight *= shading_map_factor(&m, &sp, bs.wi);
        if (!(bs.pdf_w > 0.0f) || is_black(bs.weight)) break;
        throughput *= bs.weight;
        caustic_events_add(&events, depth, bs.delta);
        prev_pdf_w = bs.pdf_w;
        prev_delta = bs.delta;
        prev_p = sp.p;
        eta_scale *= bs.eta * bs.eta;
        ray.origin = spawn_ray_origin(&sp, bs.wi);
        ray.direction = bs.wi;
#if MEDIA
        if (dot(bs.wi, sp.ng) < 0.0f) medium = medium_beyond(&sp);
#endif
        if (depth >= rr_depth && !survive_roulette(&throughput, eta_scale, u.choice.y)) break;
        ++depth;
    }
    return radiance;
}

#endif
