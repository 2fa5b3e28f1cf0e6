// Unidirectional path tracing: next-event estimation and BSDF (or phase) sampling combined by MIS
// with the power heuristic; Russian roulette on the throughput after the roulette depth.
// Depth counts scattering vertices after the camera: depth 1 sees emitters directly, so max
// depth 1 renders emission only and max depth 2 direct lighting (the convention of Mitsuba).
// Index-matched boundaries (MATERIAL_INTERFACE: interfaces and index-matched dielectrics) only
// switch the current medium and transmit their colour (the dielectric's tint, else 1); they are
// not path vertices.
#ifndef CLRENDER_PATH_H
#define CLRENDER_PATH_H

#include "aovs.h"

// A path that keeps crossing null boundaries (e.g. coincident surfaces) must still end.
#define MAX_NULL_CROSSINGS 1024

// Radiance from the environment along an escaped ray; the MIS weight uses the pdf with which
// the previous vertex sampled this direction.
float3 escaped_radiance(const Scene* scene, float3 dir, float prev_pdf_w, bool prev_delta) {
#if ENVIRONMENT != ENVIRONMENT_NONE
    float3 le = environment_radiance(scene, dir);
    if (prev_delta) return le;
    int env = scene->params->environment.x;
    float light_pdf_w = emitter_selection_pmf(scene, env) * environment_pdf_w(scene, dir);
    return le * power_heuristic(prev_pdf_w, light_pdf_w);
#else
    return (float3)(0.0f);
#endif
}

// Emission at a surface hit from the previous vertex prev_p (null boundaries may lie between).
INLINE float3 emitted_radiance(const Scene* scene, const Material* m, const SurfacePoint* sp,
                        float3 prev_p, float3 dir, float prev_pdf_w, bool prev_delta) {
    if (!sp->front_face || sp->emitter < 0) return (float3)(0.0f);
    float3 le = m->emission.xyz;
    if (prev_delta) return le;
    __global const Emitter* e = scene->emitters + sp->emitter;
    float light_pdf_w = emitter_selection_pmf(scene, sp->emitter) *
                        area_emitter_pdf_w(e, prev_p, sp->p, -dot(dir, sp->ng));
    return le * power_heuristic(prev_pdf_w, light_pdf_w);
}

#if MEDIA
// The medium on the far side of the surface from where the ray arrived.
int medium_beyond(const SurfacePoint* sp) {
    return sp->front_face ? (sp->media & 0xFFFF) - 1 : (sp->media >> 16) - 1;
}

// Transmittance from origin towards a light dist away (INFINITY for distant lights), through
// index-matched boundaries, analytic per homogeneous segment; 0 when anything else blocks it.
// Grid media: ratio tracking (null scattering; *pdf_ratio then receives the ratio of the
// unidirectional to the light technique's transmittance pdfs for MIS, see
// media/null_scattering.h) or marching; *pdf_ratio is 1 otherwise.
float3 shadow_transmittance(const Scene* scene, float3 origin, float3 dir, float dist, int medium,
                            Rng* rng, float* pdf_ratio) {
    float3 tr = (float3)(1.0f);
    float3 target = origin + dir * dist;
    *pdf_ratio = 1.0f;
#if GRID_MEDIA == VOLUME_NULL
    bool spectral_mis = scene->params->media.y != 0;
    RatioTracker tracker = ratio_tracker(rng);
#endif
    for (int crossing = 0; crossing < MAX_NULL_CROSSINGS; ++crossing) {
        float remaining = isinf(dist) ? INFINITY : dot(target - origin, dir);
        Hit hit;
        bool found = intersect_scene(scene, origin, dir, remaining * (1.0f - 1e-4f), &hit);
#if GRID_MEDIA == VOLUME_NULL
        if (medium >= 0 && !ratio_track(scene, medium, origin, dir, found ? hit.t : remaining, &tracker, rng))
            return (float3)(0.0f);
        if (!found) return tr * ratio_transmittance(&tracker, spectral_mis, pdf_ratio);
#elif GRID_MEDIA == VOLUME_RAYMARCH
        if (medium >= 0) {
            __global const Medium* md = scene->media + medium;
            float t = found ? hit.t : remaining;
            tr *= medium_is_grid(md) ? march_transmittance(scene, md, origin, dir, t, rng)
                                     : transmittance(medium_sigma_t(md), t);
        }
        if (!found) return tr;
#else
        if (medium >= 0) tr *= transmittance(medium_sigma_t(scene->media + medium), found ? hit.t : remaining);
        if (!found) return tr;
#endif
        SurfacePoint sp = surface_point(scene, &hit, dir);
        __global const Material* boundary = scene->materials + sp.material;
        if (boundary->kind.x != MATERIAL_INTERFACE) return (float3)(0.0f);
        tr *= boundary->color.xyz;
        medium = medium_beyond(&sp);
        origin = spawn_ray_origin(&sp, dir);
    }
    return (float3)(0.0f);
}
#endif

// Fraction of light arriving along a shadow ray: 0/1 visibility, or transmittance with media
// (*pdf_ratio: see shadow_transmittance; 1 without grid media).
float3 shadow_ray(const Scene* scene, float3 origin, float3 dir, float dist, int medium, Rng* rng,
                  float* pdf_ratio) {
    *pdf_ratio = 1.0f;
#if MEDIA
    return shadow_transmittance(scene, origin, dir, dist, medium, rng, pdf_ratio);
#else
    // Stop short of the light's own surface by a relative margin, valid at every scene scale.
    return occluded(scene, origin, dir, dist * (1.0f - 1e-4f)) ? (float3)(0.0f) : (float3)(1.0f);
#endif
}

INLINE float3 direct_light(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                    int medium, Rng* rng) {
    LightSample ls = sample_light(scene, sp->p, rng);
    if (!(ls.pdf_w > 0.0f) || is_black(ls.radiance)) return (float3)(0.0f);
    float3 f = eval_bsdf(scene, m, sp, wo, ls.wi);
    if (is_black(f)) return (float3)(0.0f);
    bool same_side = dot(ls.wi, sp->ng) > 0.0f;
    float3 origin = spawn_ray_origin(sp, ls.wi);
#if MEDIA
    if (!same_side) medium = medium_beyond(sp);
#endif
    float pdf_ratio;
    float3 tr = shadow_ray(scene, origin, ls.wi, ls.dist, medium, rng, &pdf_ratio);
    if (is_black(tr)) return (float3)(0.0f);
    float weight = ls.delta ? 1.0f : power_heuristic(ls.pdf_w, sample_bsdf_pdf(m, sp, wo, ls.wi) * pdf_ratio);
    return f * tr * ls.radiance * (weight / ls.pdf_w);
}

#if MEDIA
// Next-event estimation from a scattering point inside a medium; dir: the incoming travel
// direction. mis: whether phase sampling may also reach the light from here (not so for ray
// marching's single-scattering estimate, which then takes the light sample with full weight).
float3 direct_light_in_medium(const Scene* scene, float3 p, float3 dir, int medium, bool mis, Rng* rng) {
    LightSample ls = sample_light(scene, p, rng);
    if (!(ls.pdf_w > 0.0f) || is_black(ls.radiance)) return (float3)(0.0f);
    float phase = eval_phase_hg(dot(dir, ls.wi), medium_g(scene->media + medium));
    float pdf_ratio;
    float3 tr = shadow_transmittance(scene, p, ls.wi, ls.dist, medium, rng, &pdf_ratio);
    if (is_black(tr)) return (float3)(0.0f);
    float weight = (ls.delta || !mis) ? 1.0f : power_heuristic(ls.pdf_w, phase * pdf_ratio);
    return tr * ls.radiance * (phase * weight / ls.pdf_w);
}
#endif

// Survive with probability equal to the throughput without the eta^2 radiance scaling of
// refraction, capped so that bright paths (e.g. in high-albedo media) are never kept forever
// and weights stay bounded by 1 / 0.95.
bool survive_roulette(float3* throughput, float eta_scale, int depth, int rr_depth, Rng* rng) {
    if (depth < rr_depth) return true;
    float survive = fmin(max_component(*throughput) * eta_scale, 0.95f);
    if (rng_float(rng) >= survive) return false;
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
#if MEDIA
    int medium = scene->params->media.x;
    bool spectral_mis = scene->params->media.y != 0;
    int null_crossings = 0;
#else
    int medium = -1;
#endif
#if GRID_MEDIA == VOLUME_NULL
    // The segments from the last vertex (here the camera) to the next: media/null_scattering.h.
    NullChain chain;
    chain_begin(&chain, rng);
#endif
    int depth = 1;
    while (depth <= max_depth) {
        Hit hit;
        bool found = intersect_scene(scene, ray.origin, ray.direction, INFINITY, &hit);
#if MEDIA
        if (medium >= 0) {
            __global const Medium* md = scene->media + medium;
            bool lit_by_medium = false;  // next-event estimation at the scattering point done already
#if GRID_MEDIA == VOLUME_NULL
            // Every medium (homogeneous ones are a single majorant segment) by delta tracking.
            MediumEvent event = null_scattering_event(scene, medium, ray, found ? hit.t : INFINITY,
                                                      &chain, spectral_mis, rng);
#elif GRID_MEDIA == VOLUME_RAYMARCH
            MediumEvent event;
            if (medium_is_grid(md)) {
                float3 inscattered;
                event = raymarch_event(scene, medium, ray, found ? hit.t : INFINITY, depth < max_depth,
                                       &inscattered, rng);
                radiance += throughput * inscattered;
                lit_by_medium = true;
            } else {
                event = sample_medium_event(md, found ? hit.t : INFINITY, spectral_mis, rng);
            }
#else
            MediumEvent event = sample_medium_event(md, found ? hit.t : INFINITY, spectral_mis, rng);
#endif
#if AOVS
            if (event.scattered) aov_record_medium(aov, md, throughput, eta_scale);
#endif
            throughput *= event.weight;
            if (event.scattered) {
                if (depth == max_depth || is_black(throughput)) break;
                float3 p = ray.origin + event.t * ray.direction;
                if (!lit_by_medium)
                    radiance += throughput * direct_light_in_medium(scene, p, ray.direction, medium, true, rng);
                // HG is sampled exactly: phase / pdf = 1 leaves the throughput unchanged.
                ray.direction = sample_phase_hg(ray.direction, medium_g(md), rng_float2(rng), &prev_pdf_w);
                ray.origin = p;
                prev_p = p;
                prev_delta = false;
#if GRID_MEDIA == VOLUME_NULL
                chain_begin(&chain, rng);
#endif
                if (!survive_roulette(&throughput, eta_scale, depth, rr_depth, rng)) break;
                ++depth;
                continue;
            }
#if GRID_MEDIA
            if (is_black(throughput)) break;  // absorbed, or no light left through the medium
#endif
        }
#endif
#if GRID_MEDIA == VOLUME_NULL
        // The chain ends at a surface or in the distance (unless the surface is a boundary):
        // its spectral-MIS weight, and its transmittance pdfs for the emission's MIS weight.
        bool chain_ends = !found || scene->materials[scene->info[hit.prim].info.x].kind.x != MATERIAL_INTERFACE;
        if (chain_ends) {
            throughput *= chain_weight(&chain, spectral_mis);
            prev_pdf_w *= chain_pdf_ratio(&chain, spectral_mis);
            chain_begin(&chain, rng);
        }
#endif
        if (!found) {
#if AOVS
            aov_record_escape(aov, scene, ray.direction, throughput, eta_scale,
                              depth > 1 || scene->params->environment.w == 0);
#endif
            // RenderParams.environment.w (render.hide_environment): camera rays that escape,
            // through null boundaries or not, see black; the environment still lights the scene.
            if (depth > 1 || scene->params->environment.w == 0)
                radiance += throughput * escaped_radiance(scene, ray.direction, prev_pdf_w, prev_delta);
            break;
        }
        SurfacePoint sp = surface_point(scene, &hit, ray.direction);
        Material m = scene->materials[sp.material];
#if MEDIA
        if (m.kind.x == MATERIAL_INTERFACE) {
            throughput *= m.color.xyz;
            medium = medium_beyond(&sp);
            ray.origin = spawn_ray_origin(&sp, ray.direction);
            if (++null_crossings > MAX_NULL_CROSSINGS) break;
            continue;
        }
#endif
#if AOVS
        if (!material_is_delta(&m)) aov_record_surface(aov, &m, &sp, throughput, eta_scale);
#endif
        radiance += throughput * emitted_radiance(scene, &m, &sp, prev_p, ray.direction,
                                                  prev_pdf_w, prev_delta);
        if (depth == max_depth) break;
        float3 wo = -ray.direction;
#if TOON
        // Any vertex, not only the camera's: a toon surface seen in a mirror, through glass or
        // from a diffuse bounce gives its toon radiance, which already holds its lighting (it
        // counts as direct lighting, hence after the max-depth test), and the path ends.
        if (m.kind.x == MATERIAL_TOON) {
            radiance += throughput * eval_toon_radiance(scene, &m, &sp, wo, medium, rng);
            break;
        }
#endif
        if (!material_is_delta(&m)) radiance += throughput * direct_light(scene, &m, &sp, wo, medium, rng);

        BsdfSample bs = sample_bsdf(scene, &m, &sp, wo, rng);
        if (!(bs.pdf_w > 0.0f) || is_black(bs.weight)) break;
        throughput *= bs.weight;
        prev_pdf_w = bs.pdf_w;
        prev_delta = bs.delta;
        prev_p = sp.p;
        eta_scale *= bs.eta * bs.eta;
        ray.origin = spawn_ray_origin(&sp, bs.wi);
        ray.direction = bs.wi;
#if MEDIA
        if (dot(bs.wi, sp.ng) < 0.0f) medium = medium_beyond(&sp);
#endif
        if (!survive_roulette(&throughput, eta_scale, depth, rr_depth, rng)) break;
        ++depth;
    }
    return radiance;
}

#endif
