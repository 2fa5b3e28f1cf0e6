// Path tracing of LANES paths at once (lanes.h: 8 on CPUs), each lane a camera path: path.h's
// estimator (next-event estimation and BSDF sampling combined by the power heuristic, Russian
// roulette on the throughput without eta^2) for the scenes features.py gives this integrator:
// diffuse, smooth dielectric, smooth and rough conductor surfaces (no energy compensation),
// triangle and sphere emitters, no media, environment or toon. A lane's path ends by clearing its bit of `alive`; the loop runs while any lane lives.
// Every lane draws the same sampler dimensions at each step, as each path of path.h does, so a
// lane traces the path that path.h traces for its pixel (the images agree to float rounding).
#ifndef CLRENDER_PATH_PACKETS_H
#define CLRENDER_PATH_PACKETS_H
#include "lanes.h"
#include "math.h"
#include "rng.h"
#include "sampling.h"
#include "camera.h"
#include "scene.h"
#include "triangle_lights.h"
#include "area_lights.h"
#include "materials/material.h"
#include "materials/diffuse.h"
#include "materials/dielectric_smooth.h"
#include "materials/conductor_smooth.h"
#include "materials/conductor.h"

// The lanes' glossy lobe (path.h's rough conductors): where `rough`, a microfacet conductor of
// tint `tint` (black seen from a one-sided back), its surface and complex index, about the
// specular normal n (bsdf.h, specular_normal).
typedef struct {
    lane_int rough;
#if DIELECTRIC
    lane_float3 tint, eta, k, n;
    Microfacet mf;
#endif
} GlossyLanes;

GlossyLanes glossy_lanes(const Scene* scene, const SurfacePoint* sp, lane_int conductor, lane_float3 tint,
                         lane_float3 wo) {
    GlossyLanes g;
    g.rough = 0;
#if DIELECTRIC
    if (!lane_any(conductor)) return g;
    g.mf = material_microfacet_at(scene->materials, sp->material);
    g.rough = conductor & (g.mf.alpha >= MICROFACET_MIN_ALPHA);   // bsdf.h, material_is_delta
    if (!lane_any(g.rough)) return g;
    g.tint = tint;
    g.eta = material_conductor_eta_at(scene->materials, sp->material);
    g.k = material_conductor_k_at(scene->materials, sp->material);
    g.n = l3_select(sp->ng, sp->ns, l3_dot(wo, sp->ns) > 0.0f);
#endif
    return g;
}

// bsdf.h's eval_bsdf and sample_bsdf_pdf at the rough lanes: f * cos of direction wi and the
// density of sampling it, 0 where the normals disagree.
lane_float3 eval_glossy_lanes(const GlossyLanes* g, const SurfacePoint* sp, lane_float3 wo, lane_float3 wi,
                              lane_float* pdf_w) {
#if DIELECTRIC
    lane_int agree = g->rough & sides_agree(l3_dot(wi, sp->ng), l3_dot(wi, g->n));
    *pdf_w = select((lane_float)(0.0f), sample_conductor_pdf(g->mf, g->n, wo, wi), agree);
    return l3_select(l3_splat(0.0f), eval_conductor(g->tint, g->eta, g->k, g->mf, g->n, wo, wi), agree);
#else
    *pdf_w = 0.0f;
    return l3_splat(0.0f);
#endif
}

// Emission of the surfaces hit (front faces of emitting triangles and spheres), weighted against
// the light-sampling density of reaching them from the previous vertex (path.h, emitted_radiance).
lane_float3 emitted_radiance_lanes(const Scene* scene, const SurfacePoint* sp, lane_float3 prev_p,
                                   lane_float3 dir, lane_float prev_pdf_w, lane_int prev_delta) {
    lane_int emits = sp->front_face & (sp->emitter >= 0);
    if (!lane_any(emits)) return l3_splat(0.0f);
    lane_int emitter = max(sp->emitter, (lane_int)(0));   // (Oclgrind gets integer max(vector, scalar) wrong)
    lane_float3 le = material_emission_at(scene->materials, sp->material);
    lane_float light_pdf_w = emitter_selection_pmf(scene, emitter) *
                             area_emitter_pdf_w(scene->emitters, emitter, prev_p, sp->p, -l3_dot(dir, sp->ng));
    lane_float weight = select(power_heuristic(prev_pdf_w, light_pdf_w), (lane_float)(1.0f), prev_delta);
    return l3_select(l3_splat(0.0f), l3_scale(le, weight), emits);
}

// Next-event estimation at the diffuse and rough vertices of `lanes` (path.h, direct_light), from
// the 2D draw u: an emitter picked (light_selection.py), a point on it, a shadow ray.
lane_float3 direct_light_lanes(const Scene* scene, const SurfacePoint* sp, lane_float3 albedo,
                               const GlossyLanes* glossy, lane_float3 wo, lane_float2 u, lane_int lanes) {
    int count = scene->params->config.w;
    lane_float3 radiance = l3_splat(0.0f);
    if (count == 0 || !lane_any(lanes)) return radiance;
    lane_float u_on_emitter;
    lane_int index = sample_discrete_cdf_reuse(scene->emitter_cdf, count, u.x, &u_on_emitter);
    lane_float2 u_emitter = make_lane_float2(u_on_emitter, u.y);
    lane_int sphere = LANE_LOAD_INT(scene->emitters, index, .kind.x) == EMITTER_SPHERE;
    lane_float dist = 0.0f, pdf_w = 0.0f;
    lane_float3 wi = l3_splat(0.0f);
    if (lane_any(!sphere)) wi = sample_triangle_emitter(scene, index, sp->p, u_emitter, &dist, &pdf_w);
    if (lane_any(sphere)) {   // lights.h, sample_light
        lane_float sphere_pdf_w;
        lane_float3 d = l3_sub(sample_sphere_emitter(scene->emitters, index, sp->p, u_emitter, &sphere_pdf_w), sp->p);
        lane_float sphere_dist = l3_length(d);
        wi = l3_select(wi, l3_div(d, sphere_dist), sphere);
        dist = select(dist, sphere_dist, sphere);
        pdf_w = select(pdf_w, sphere_pdf_w, sphere);
    }
    lane_float light_pdf_w = emitter_selection_pmf(scene, index) * pdf_w;
    lane_float3 le = LANE_LOAD3(scene->emitters, index, .radiance);
    lane_float3 f = eval_diffuse(albedo, sp, wi);
    lane_float bsdf_pdf_w = sample_diffuse_pdf(sp, wi);
    if (lane_any(glossy->rough & lanes)) {
        lane_float glossy_pdf_w;
        f = l3_select(f, eval_glossy_lanes(glossy, sp, wo, wi, &glossy_pdf_w), glossy->rough);
        bsdf_pdf_w = select(bsdf_pdf_w, glossy_pdf_w, glossy->rough);
    }
    lane_int lit = lanes & (dist > 0.0f) & (light_pdf_w > 0.0f) & !is_black(le) & !is_black(f);
    if (!lane_any(lit)) return radiance;
    // Stop short of the light's own surface by a relative margin, valid at every scene scale.
    lit &= !any_hits(scene, spawn_ray_origin(sp, wi), wi, dist * (1.0f - 1e-4f), lit);
    lane_float weight = power_heuristic(light_pdf_w, bsdf_pdf_w);
    return l3_select(radiance, l3_scale(l3_mul(f, le), weight / light_pdf_w), lit);
}

// The scattering of the lanes' vertices: the diffuse lobe; where `smooth`, the smooth
// dielectric's pair of delta lobes (picked with u_lobe, path.h's rnl), or where also `conductor`
// the conductor's mirror; where glossy->rough, the rough conductor's lobe (bsdf.h,
// sample_specular_bsdf: eval / pdf, none where the normals disagree).
BsdfSample sample_bsdf_lanes(const Scene* scene, const SurfacePoint* sp, lane_float3 color, lane_float3 wo,
                             lane_int smooth, lane_int conductor, const GlossyLanes* glossy, lane_float u_lobe,
                             lane_float2 u, lane_int lanes) {
    BsdfSample bs = bsdf_sample_none();
    bs.wi = sample_diffuse(sp, u);
    bs.pdf_w = sample_diffuse_pdf(sp, bs.wi);
    // For cosine sampling f * cos / pdf is the albedo itself.
    bs.weight = l3_select(l3_splat(0.0f), color, bs.pdf_w > 0.0f);
#if DIELECTRIC
    lane_int rough = glossy->rough & lanes;
    if (lane_any(rough)) {
        lane_float3 wi = sample_conductor(glossy->mf, glossy->n, wo, u);
        lane_float pdf_w;
        lane_float3 f = eval_glossy_lanes(glossy, sp, wo, wi, &pdf_w);
        lane_int valid = pdf_w > 0.0f;   // also rejects the zero vector: its cosines are 0
        bs.wi = l3_select(bs.wi, wi, rough);
        bs.pdf_w = select(bs.pdf_w, select((lane_float)(0.0f), pdf_w, valid), rough);
        bs.weight = l3_select(bs.weight, l3_select(l3_splat(0.0f), l3_div(f, pdf_w), valid), rough);
    }
    smooth &= lanes;
    if (!lane_any(smooth)) return bs;
    lane_float3 n = l3_select(sp->ng, sp->ns, l3_dot(wo, sp->ns) > 0.0f);   // bsdf.h, specular_normal
    conductor &= smooth;
    lane_int glass = smooth & !conductor;
    if (lane_any(glass)) {
        lane_float ior = material_ior_at(scene->materials, sp->material);
        lane_float exterior = material_exterior_ior_at(scene->materials, sp->material);
        lane_float eta = select(exterior / ior, ior / exterior, sp->front_face);  // bsdf.h, material_eta
        BsdfSample delta = sample_dielectric_delta(l3_splat(1.0f), color, eta, n, sp->ng, wo, u_lobe);
        bs.wi = l3_select(bs.wi, delta.wi, glass);
        bs.weight = l3_select(bs.weight, delta.weight, glass);
        bs.pdf_w = select(bs.pdf_w, delta.pdf_w, glass);
        bs.eta = select(bs.eta, delta.eta, glass);
    }
    if (lane_any(conductor)) {
        BsdfSample mirror = sample_conductor_delta(color, material_conductor_eta_at(scene->materials, sp->material),
                                                   material_conductor_k_at(scene->materials, sp->material), n,
                                                   sp->ng, wo);
        bs.wi = l3_select(bs.wi, mirror.wi, conductor);
        bs.weight = l3_select(bs.weight, mirror.weight, conductor);
        bs.pdf_w = select(bs.pdf_w, mirror.pdf_w, conductor);
    }
    bs.delta = smooth;
#endif
    return bs;
}

// The sample-level AOVs of the lanes' paths (aovs.h, AovSample): those of the first non-delta
// vertex; a path that escapes or ends before one records zeros, as aovs.h's do without an
// environment.
typedef struct {
    lane_float3 albedo;
    lane_float3 normal;
    lane_float3 emission;
    lane_int found;
} AovLanes;

// aovs.h, aov_record_surface, at the diffuse vertices of `lanes` that record nothing yet.
void aov_record_surfaces(const Scene* scene, AovLanes* aov, const SurfacePoint* sp, lane_float3 color,
                         lane_float3 throughput, lane_float eta_scale, lane_int lanes) {
    lanes &= !aov->found;
    if (!AOVS || !lane_any(lanes)) return;
    lane_int emits = sp->front_face & (sp->emitter >= 0);
    lane_float3 emission = material_emission_at(scene->materials, sp->material);
    lane_float3 colour = l3_select(color, l3_scale(emission, 1.0f / fmax(max_component(emission), 1.0f)), emits);
    lane_float3 filter = make_lane_float3(clamp(throughput.x * eta_scale, 0.0f, 1.0f),
                                          clamp(throughput.y * eta_scale, 0.0f, 1.0f),
                                          clamp(throughput.z * eta_scale, 0.0f, 1.0f));
    aov->albedo = l3_select(aov->albedo, l3_mul(filter, colour), lanes);
    aov->normal = l3_select(aov->normal, sp->ns, lanes);
    aov->emission = l3_select(aov->emission, l3_select(l3_splat(0.0f), l3_mul(throughput, emission), emits), lanes);
    aov->found |= lanes;
}

// The radiance of the lanes' camera paths (0 in lanes not `alive` at the start); with AOVS,
// *aov receives their sample-level AOVs.
lane_float3 trace_paths(const Scene* scene, Ray ray, lane_int alive, Rng* rng, AovLanes* aov) {
    int max_depth = scene->params->config.x;
    int rr_depth = scene->params->config.y;
    lane_float3 radiance = l3_splat(0.0f);
    lane_float3 throughput = l3_splat(1.0f);
    lane_float3 prev_p = ray.origin;
    lane_float prev_pdf_w = 0.0f;
    lane_int prev_delta = LANE_TRUE;   // the camera ray sees emitters with full weight
    lane_float eta_scale = 1.0f;       // path.h: roulette on the throughput without eta^2
    for (int depth = 1; depth <= max_depth; ++depth) {
        LaneHit hit;
        alive = closest_hits(scene, ray.origin, ray.direction, INFINITY, alive, &hit);
        if (!lane_any(alive)) break;
        SurfacePoint sp = surface_point(scene, &hit, ray.direction);
        // Smooth dielectrics and conductors: delta lobes; rough conductors: glossy ones
        // (features.py gives packets no rough dielectrics).
        lane_int kind = material_kind_at(scene->materials, sp.material);
        lane_int conductor = kind == MATERIAL_CONDUCTOR;
        // A one-sided material seen from behind is black (bsdf.h, is_one_sided_back): no light
        // reaches it, and the path ends there.
        lane_int black_back = (material_one_sided_at(scene->materials, sp.material) != 0) & !sp.front_face;
        lane_float3 color = l3_select(material_color_at(scene->materials, sp.material), l3_splat(0.0f), black_back);
        lane_float3 wo = l3_neg(ray.direction);
        GlossyLanes glossy = glossy_lanes(scene, &sp, conductor, color, wo);
        lane_int smooth = (kind == MATERIAL_DIELECTRIC) | (conductor & !glossy.rough);
        aov_record_surfaces(scene, aov, &sp, color, throughput, eta_scale, alive & !smooth);
        lane_float3 emitted = emitted_radiance_lanes(scene, &sp, prev_p, ray.direction, prev_pdf_w, prev_delta);
        radiance = l3_select(radiance, l3_add(radiance, l3_mul(throughput, emitted)), alive);
        if (depth == max_depth) break;
        // A diffuse or rough vertex draws its light sample, a smooth one its lobe (rng_float, the
        // first coordinate of the same dimension); the independent sampler's 2D draw takes two
        // numbers where rng_float takes one, so the smooth lanes give one back.
        lane_float2 u_light = rng_float2(rng);
        if (rng->sampler != SAMPLER_SOBOL) rng->counter -= select((lane_uint)(0u), (lane_uint)(1u), smooth);
        lane_float3 direct = direct_light_lanes(scene, &sp, color, &glossy, wo, u_light, alive & !smooth);
        // A rough vertex then draws its lobe's number as a smooth one did (bsdf.h, sample_bsdf),
        // which a conductor does not use; the other lanes give it back.
        if (lane_any(glossy.rough)) {
            rng_float(rng);
            rng->counter -= select((lane_uint)(1u), (lane_uint)(0u), glossy.rough);
        }
        // Selected, not added everywhere: the throughput of a finished lane may be anything.
        radiance = l3_select(radiance, l3_add(radiance, l3_mul(throughput, direct)), alive);
        BsdfSample bs = sample_bsdf_lanes(scene, &sp, color, wo, smooth, conductor, &glossy, u_light.x, rng_float2(rng),
                                          alive);
        alive &= (bs.pdf_w > 0.0f) & !is_black(bs.weight) & !black_back;
        throughput = l3_mul(throughput, bs.weight);
        prev_pdf_w = bs.pdf_w;
        prev_delta = bs.delta;
        prev_p = sp.p;
        eta_scale *= bs.eta * bs.eta;
        ray.origin = spawn_ray_origin(&sp, bs.wi);
        ray.direction = bs.wi;
        if (depth >= rr_depth) {
            // path.h, survive_roulette
            lane_float survive = fmin(max_component(throughput) * eta_scale, 0.95f);
            alive &= rng_float(rng) < survive;
            throughput = l3_div(throughput, survive);
        }
        if (!lane_any(alive)) break;
    }
    return radiance;
}

#endif
