// Unidirectional path tracing: next-event estimation and BSDF sampling combined by MIS with the
// power heuristic; Russian roulette on the throughput after the roulette depth.
// Depth counts path vertices after the camera: depth 1 sees emitters directly, so max depth 1
// renders emission only and max depth 2 direct lighting (the convention of Mitsuba).
#ifndef CLRENDER_PATH_H
#define CLRENDER_PATH_H

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

float3 emitted_radiance(const Scene* scene, const Material* m, const SurfacePoint* sp, float t,
                        float3 dir, float prev_pdf_w, bool prev_delta) {
    if (!sp->front_face || sp->emitter < 0) return (float3)(0.0f);
    float3 le = m->emission.xyz;
    if (prev_delta) return le;
    __global const Emitter* e = scene->emitters + sp->emitter;
    float light_pdf_w = emitter_selection_pmf(scene, sp->emitter) *
                        triangle_emitter_pdf_w(e, t, -dot(dir, sp->ng));
    return le * power_heuristic(prev_pdf_w, light_pdf_w);
}

float3 direct_light(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wo,
                    Rng* rng) {
    LightSample ls = sample_light(scene, sp->p, rng);
    if (!(ls.pdf_w > 0.0f) || is_black(ls.radiance)) return (float3)(0.0f);
    float3 f = eval_bsdf(scene, m, sp, wo, ls.wi);
    if (is_black(f)) return (float3)(0.0f);
    float3 origin = spawn_ray_origin(sp, ls.wi);
    // Stop short of the light's own surface by a relative margin, valid at every scene scale.
    if (occluded(scene, origin, ls.wi, ls.dist * (1.0f - 1e-4f))) return (float3)(0.0f);
    float weight = ls.delta ? 1.0f : power_heuristic(ls.pdf_w, sample_bsdf_pdf(m, sp, wo, ls.wi));
    return f * ls.radiance * (weight / ls.pdf_w);
}

float3 trace_path(const Scene* scene, Ray ray, Rng* rng) {
    int max_depth = scene->params->config.x;
    int rr_depth = scene->params->config.y;
    float3 radiance = (float3)(0.0f);
    float3 throughput = (float3)(1.0f);
    float prev_pdf_w = 0.0f;
    bool prev_delta = true;  // the camera ray sees emitters with full weight
    // Product of eta^2 over the refractions so far: throughput * eta_scale is the throughput
    // without the radiance scaling of refraction (see materials/dielectric.h), which roulette
    // must use, or it would kill paths for being inside glass (pbrt-v4's etaScale).
    float eta_scale = 1.0f;
    for (int depth = 1; depth <= max_depth; ++depth) {
        Hit hit;
        if (!intersect_scene(scene, ray.origin, ray.direction, INFINITY, &hit)) {
            radiance += throughput * escaped_radiance(scene, ray.direction, prev_pdf_w, prev_delta);
            break;
        }
        SurfacePoint sp = surface_point(scene, &hit, ray.direction);
        Material m = scene->materials[sp.material];
        radiance += throughput * emitted_radiance(scene, &m, &sp, hit.t, ray.direction,
                                                  prev_pdf_w, prev_delta);
        if (depth == max_depth) break;
        float3 wo = -ray.direction;
        if (!material_is_delta(&m)) radiance += throughput * direct_light(scene, &m, &sp, wo, rng);

        BsdfSample bs = sample_bsdf(scene, &m, &sp, wo, rng);
        if (!(bs.pdf_w > 0.0f) || is_black(bs.weight)) break;
        throughput *= bs.weight;
        prev_pdf_w = bs.pdf_w;
        prev_delta = bs.delta;
        eta_scale *= bs.eta * bs.eta;
        ray.origin = spawn_ray_origin(&sp, bs.wi);
        ray.direction = bs.wi;

        if (depth >= rr_depth) {
            // Survive with probability equal to the throughput, without the eta^2 radiance
            // scaling (capped so that bright paths are never killed).
            float survive = fmin(max_component(throughput) * eta_scale, 0.95f);
            if (rng_float(rng) >= survive) break;
            throughput /= survive;
        }
    }
    return radiance;
}

#endif
