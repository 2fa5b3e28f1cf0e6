// Path tracing of LANES paths at once (lanes.h: 8 on CPUs), each lane a camera path: path.h's
// estimator (next-event estimation and BSDF sampling combined by the power heuristic, Russian
// roulette on the throughput without eta^2) for the scenes features.py gives this integrator:
// diffuse, smooth and rough dielectric and conductor surfaces (no energy compensation), plastic,
// colours and masks (opacity) from textures, triangle and sphere emitters, point, spot and
// directional lights, the environment (constant or image), no media or toon. A lane's path ends by clearing its bit of `alive`; the loop runs
// while any lane lives.
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
#include "delta_lights.h"
#include "environment.h"
#include "materials/material.h"
#include "materials/diffuse.h"
#include "materials/dielectric_smooth.h"
#include "materials/conductor_smooth.h"
#include "materials/conductor.h"
#include "materials/dielectric.h"
#include "materials/plastic.h"
#include "materials/textured_params.h"
#include "light_paths.h"

// The lanes' glossy lobes (bsdf.h's rough dielectrics and conductors, without energy
// compensation, and plastic), about the specular normal n (bsdf.h, specular_normal): where
// `rough`, a microfacet surface; where also `dielectric` an interface of relative index eta,
// transmission tinted by `tint` and reflection untinted (features.py), else a conductor of tint
// `tint` and complex index eta_rgb + i k; where `plastic`, the plastic p (its base coloured by
// `tint`). One-sided backs are black: both tints 0, and no plastic.
typedef struct {
    lane_int rough, dielectric, plastic;
#if DIELECTRIC
    lane_float3 tint, reflect_tint, eta_rgb, k, n;
    lane_float eta;
    Microfacet mf;
    Plastic p;
#endif
} GlossyLanes;

GlossyLanes glossy_lanes(const Scene* scene, const SurfacePoint* sp, lane_int kind, lane_float3 tint,
                         lane_int black_back, lane_float3 wo) {
    GlossyLanes g;
    g.rough = 0;
    g.dielectric = 0;
    g.plastic = 0;
#if DIELECTRIC
    lane_int specular = (kind == MATERIAL_CONDUCTOR) | (kind == MATERIAL_DIELECTRIC);
    lane_int plastic = (kind == MATERIAL_PLASTIC) & !black_back;
    if (!lane_any(specular | plastic)) return g;
    g.n = l3_select(sp->ng, sp->ns, l3_dot(wo, sp->ns) > 0.0f);
    g.mf = material_microfacet_at(scene->materials, sp->material);
    g.rough = specular & (g.mf.alpha >= MICROFACET_MIN_ALPHA);   // bsdf.h, material_is_delta
    g.mf = microfacet_of_lanes(g.mf, g.rough | plastic);
    if (lane_any(plastic)) {
        g.plastic = plastic;
        g.p = plastic_lanes(scene, sp->material, plastic, tint, g.mf);
    }
    if (!lane_any(g.rough)) return g;
    g.dielectric = g.rough & (kind == MATERIAL_DIELECTRIC);
    g.tint = tint;
    g.reflect_tint = l3_select(l3_splat(1.0f), l3_splat(0.0f), black_back);
    g.eta_rgb = material_conductor_eta_at(scene->materials, sp->material);
    g.k = material_conductor_k_at(scene->materials, sp->material);
    lane_float ior = material_ior_at(scene->materials, sp->material);
    lane_float exterior = material_exterior_ior_at(scene->materials, sp->material);
    g.eta = select((lane_float)(1.0f), select(exterior / ior, ior / exterior, sp->front_face),  // bsdf.h, material_eta
                   g.dielectric);
#endif
    return g;
}

// bsdf.h's eval_bsdf and sample_bsdf_pdf at the rough and plastic lanes of `lanes`: f * cos of
// direction wi and the density of sampling it, 0 where the normals disagree.
lane_float3 eval_glossy_lanes(const GlossyLanes* g, const SurfacePoint* sp, lane_float3 wo, lane_float3 wi,
                              lane_float* pdf_w, lane_int lanes) {
    lane_float3 f = l3_splat(0.0f);
    *pdf_w = 0.0f;
#if DIELECTRIC
    lane_int agree = lanes & sides_agree(l3_dot(wi, sp->ng), l3_dot(wi, g->n));
    lane_int dielectric = agree & g->rough & g->dielectric, conductor = agree & g->rough & !g->dielectric;
    lane_int plastic = agree & g->plastic;
    if (lane_any(plastic)) {
        lane_float pdf_plastic;
        f = l3_select(f, eval_pdf_plastic(&g->p, g->n, wo, wi, &pdf_plastic), plastic);
        *pdf_w = select(*pdf_w, pdf_plastic, plastic);
    }
    if (lane_any(dielectric)) {
        lane_float pdf_dielectric;
        f = l3_select(f, eval_pdf_dielectric(g->reflect_tint, g->tint, g->eta, g->mf, g->n, wo, wi, &pdf_dielectric),
                      dielectric);
        *pdf_w = select(*pdf_w, pdf_dielectric, dielectric);
    }
    if (lane_any(conductor)) {
        lane_float pdf_conductor;
        f = l3_select(f, eval_pdf_conductor(g->tint, g->eta_rgb, g->k, g->mf, g->n, wo, wi, &pdf_conductor),
                      conductor);
        *pdf_w = select(*pdf_w, pdf_conductor, conductor);
    }
#endif
    return f;
}

// bsdf.h's sample_specular_bsdf and sample_plastic_bsdf at the rough and plastic lanes of
// `lanes`, from the lobe's numbers rnl and rn.
BsdfSample sample_glossy_lanes(const GlossyLanes* g, const SurfacePoint* sp, lane_float3 wo, lane_float rnl,
                               lane_float2 rn, lane_int lanes) {
    BsdfSample bs = bsdf_sample_none();
#if DIELECTRIC
    lane_int rough = lanes & g->rough, plastic = lanes & g->plastic;
    if (lane_any(rough)) {
        lane_float3 wi = l3_splat(0.0f);
        lane_int dielectric = rough & g->dielectric, conductor = rough & !g->dielectric;
        if (lane_any(dielectric)) wi = l3_select(wi, sample_dielectric(g->eta, g->mf, g->n, wo, rnl, rn), dielectric);
        if (lane_any(conductor)) wi = l3_select(wi, sample_conductor(g->mf, g->n, wo, rn), conductor);
        lane_float pdf_w;
        lane_float3 f = eval_glossy_lanes(g, sp, wo, wi, &pdf_w, rough);
        lane_int valid = pdf_w > 0.0f;   // also rejects the zero vector: its cosines are 0
        bs.wi = l3_select(bs.wi, wi, rough);
        bs.pdf_w = select(bs.pdf_w, pdf_w, valid);
        bs.weight = l3_select(bs.weight, l3_div(f, pdf_w), valid);
        bs.eta = select(bs.eta, g->eta, rough & (l3_dot(wi, sp->ng) < 0.0f));
    }
    if (lane_any(plastic)) {
        BsdfSample scattered = sample_plastic(&g->p, g->n, sp->ng, wo, rnl, rn);
        // A scattered (not mirrored) direction counts where the normals agree.
        plastic &= (scattered.delta != 0) | sides_agree(l3_dot(scattered.wi, sp->ng), l3_dot(scattered.wi, g->n));
        bs.wi = l3_select(bs.wi, scattered.wi, plastic);
        bs.pdf_w = select(bs.pdf_w, scattered.pdf_w, plastic);
        bs.weight = l3_select(bs.weight, scattered.weight, plastic);
        bs.delta = select(bs.delta, scattered.delta, plastic);
    }
#endif
    return bs;
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

// The lanes' light samples from p (lights.h, sample_light), from the 2D draw u: an emitter picked
// (light_selection.py; its probability in *pmf) and the direction *wi to it, the distance *dist
// (not > 0: no sample), the solid-angle density *pdf_w of that direction (1 for a point, spot or
// directional light, a delta), the radiance arriving; where *delta, such a light (delta_lights.h).
// Where *environment, the environment: its radiance 1 until the caller looks up its (u, v) *env_uv
// (environment_radiance_at) once the shadow ray has passed, as lights.h's light_sample_radiance.
lane_float3 sample_light_lanes(const Scene* scene, lane_float3 p, lane_float2 u, lane_float3* wi, lane_float* dist,
                               lane_float* pdf_w, lane_float* pmf, lane_int* delta, lane_int* environment,
                               lane_float2* env_uv) {
    lane_float u_on_emitter;
    lane_int index = sample_discrete_cdf_reuse(scene->emitter_cdf, scene->params->config.w, u.x, &u_on_emitter);
    *pmf = emitter_selection_pmf(scene, index);
    lane_float2 u_emitter = make_lane_float2(u_on_emitter, u.y);
    lane_int kind = LANE_LOAD_INT(scene->emitters, index, .kind.x);
    lane_int triangle = kind == EMITTER_TRIANGLE, sphere = kind == EMITTER_SPHERE;
    lane_float3 radiance = LANE_LOAD3(scene->emitters, index, .radiance);
    *wi = l3_splat(0.0f);
    *dist = 0.0f;
    *pdf_w = 0.0f;
    *delta = (kind == EMITTER_POINT) | (kind == EMITTER_SPOT) | (kind == EMITTER_DIRECTIONAL);
    if (lane_any(triangle)) {
        lane_float triangle_dist, triangle_pdf_w;
        lane_float3 w = sample_triangle_emitter(scene, index, p, u_emitter, &triangle_dist, &triangle_pdf_w);
        *wi = l3_select(*wi, w, triangle);
        *dist = select(*dist, triangle_dist, triangle);
        *pdf_w = select(*pdf_w, triangle_pdf_w, triangle);
    }
    if (lane_any(sphere)) {
        lane_float sphere_pdf_w;
        lane_float3 d = l3_sub(sample_sphere_emitter(scene->emitters, index, p, u_emitter, &sphere_pdf_w), p);
        lane_float sphere_dist = l3_length(d);
        *wi = l3_select(*wi, l3_div(d, sphere_dist), sphere);
        *dist = select(*dist, sphere_dist, sphere);
        *pdf_w = select(*pdf_w, sphere_pdf_w, sphere);
    }
    *environment = kind == EMITTER_ENVIRONMENT;
    *env_uv = make_lane_float2(0.0f, 0.0f);   // a valid (u, v) in every lane
#if ENVIRONMENT != ENVIRONMENT_NONE
    if (lane_any(*environment)) {
        lane_float env_pdf_w;
        lane_float2 uv;
        lane_float3 w = sample_environment_direction(scene, u_emitter, &env_pdf_w, &uv);
        *wi = l3_select(*wi, w, *environment);
        *dist = select(*dist, (lane_float)(INFINITY), *environment);
        *pdf_w = select(*pdf_w, env_pdf_w, *environment);
        *env_uv = make_lane_float2(select(env_uv->x, uv.x, *environment), select(env_uv->y, uv.y, *environment));
        radiance = l3_select(radiance, l3_splat(1.0f), *environment);
    }
#endif
    if (lane_any(*delta)) {
        lane_float3 delta_wi, delta_radiance;
        lane_float delta_dist;
        lane_int arrives = delta_light_arriving(scene->emitters, index, p, &delta_wi, &delta_dist, &delta_radiance);
        *wi = l3_select(*wi, delta_wi, arrives);
        *dist = select(*dist, delta_dist, arrives);
        *pdf_w = select(*pdf_w, (lane_float)(1.0f), arrives);
        radiance = l3_select(radiance, delta_radiance, *delta);
    }
    return radiance;
}

// Some surface (its primitive slot) on each of the `lanes`' shadow rays from origin to dist, short
// of the light's own surface; -1 where there is none. `coherent`: the rays leave adjacent camera
// hits and the caller does not ask which surface blocks them (coherent_occluders).
lane_int shadow_blockers(const Scene* scene, lane_float3 origin, lane_float3 dir, lane_float dist, lane_int lanes,
                         bool coherent) {
    // A relative margin, valid at every scene scale.
    lane_float t_max = dist * (1.0f - 1e-4f);
    return coherent ? coherent_occluders(scene, origin, dir, t_max, lanes) : occluders(scene, origin, dir, t_max, lanes);
}

#if TEXTURES
// The fraction of light reaching dist along the `lanes`' shadow rays from origin (path.h's
// shadow_ray): 1 where nothing is in the way, 0 where an unmasked surface is, else the product of
// 1 - opacity over the masks crossed (media/transport.h, shadow_transmittance); 0 in other lanes.
// `coherent`: the rays leave adjacent camera hits, and no surface is a mask (coherent_occluders).
lane_float shadow_transmittance_lanes(const Scene* scene, lane_float3 origin, lane_float3 dir, lane_float dist,
                                      lane_int lanes, bool coherent) {
    lane_int blocker = shadow_blockers(scene, origin, dir, dist, lanes, coherent);
    lane_float tr = select((lane_float)(0.0f), (lane_float)(1.0f), lanes & (blocker < 0));
    // Any blocker ends an unmasked shadow ray; a mask needs the surfaces in order.
    lane_int through = (blocker >= 0) & material_masked_at(scene->materials, LANE_LOAD_INT(scene->info, max(blocker, (lane_int)(0)), .info.x));
    if (!lane_any(through)) return tr;
    tr = select(tr, (lane_float)(1.0f), through);
    lane_float3 target = l3_add(origin, l3_scale(dir, dist));
    for (int crossing = 0; crossing < MAX_NULL_CROSSINGS; ++crossing) {
        lane_float remaining = select(l3_dot(l3_sub(target, origin), dir), (lane_float)(INFINITY), isinf(dist));
        LaneHit hit;
        lane_int found = closest_hits(scene, origin, dir, remaining * (1.0f - 1e-4f), through, &hit);
        through &= found;
        if (!lane_any(through)) return tr;
        SurfacePoint sp = surface_point(scene, &hit, dir);
        lane_int masked = material_masked_at(scene->materials, sp.material);
        lane_float opacity = surface_opacity_lanes(scene, &hit, sp.material, through & masked);
        tr = select(tr, tr * select((lane_float)(0.0f), 1.0f - opacity, masked), through);
        through &= tr > 0.0f;
        origin = l3_select(origin, spawn_ray_origin(&sp, dir), through);
    }
    return select(tr, (lane_float)(0.0f), through);
}
#endif

// Next-event estimation at the diffuse, rough and plastic vertices of `lanes` (path.h,
// direct_light), from the 2D draw u: a light sample, a shadow ray; bsdf_share scales the BSDF
// technique's pdf in the MIS weight as there; `coherent` as shadow_transmittance_lanes.
lane_float3 direct_light_lanes(const Scene* scene, const SurfacePoint* sp, lane_float3 albedo,
                               const GlossyLanes* glossy, lane_float3 wo, lane_float2 u, lane_int lanes,
                               float bsdf_share, bool coherent) {
    lane_float3 radiance = l3_splat(0.0f);
    if (scene->params->config.w == 0 || !lane_any(lanes)) return radiance;
    lane_float3 wi;
    lane_float dist, pdf_w, pmf;
    lane_int delta, environment;
    lane_float2 env_uv;
    lane_float3 le = sample_light_lanes(scene, sp->p, u, &wi, &dist, &pdf_w, &pmf, &delta, &environment, &env_uv);
    lane_float light_pdf_w = pmf * pdf_w;
    lane_float3 f = eval_diffuse(albedo, sp, wi);
    lane_float bsdf_pdf_w = 0.0f;   // the diffuse lanes' below, where MIS needs it
    lane_int glossy_lanes = (glossy->rough | glossy->plastic) & lanes;
    if (lane_any(glossy_lanes)) {
        lane_float glossy_pdf_w;
        f = l3_select(f, eval_glossy_lanes(glossy, sp, wo, wi, &glossy_pdf_w, glossy_lanes), glossy_lanes);
        bsdf_pdf_w = select(bsdf_pdf_w, glossy_pdf_w, glossy_lanes);
    }
    lane_int lit = lanes & (dist > 0.0f) & (light_pdf_w > 0.0f) & !is_black(le) & !is_black(f);
    if (!lane_any(lit)) return radiance;
    // (A delta light's sample weighs 1: only the others need the diffuse density, which with a
    // caustic guide costs lookups.)
    lane_int diffuse_mis = lit & !delta & !glossy_lanes;
    if (lane_any(diffuse_mis)) bsdf_pdf_w = select(bsdf_pdf_w, sample_diffuse_pdf(scene, sp, wi), diffuse_mis);
#if ENVIRONMENT == ENVIRONMENT_IMAGE
    prefetch_environment_texels(scene, env_uv, lit & environment);
#endif
#if TEXTURES
    lane_float tr = shadow_transmittance_lanes(scene, spawn_ray_origin(sp, wi), wi, dist, lit, coherent);
    lit &= tr > 0.0f;
    f = l3_scale(f, tr);
#else
    lit &= shadow_blockers(scene, spawn_ray_origin(sp, wi), wi, dist, lit, coherent) < 0;
#endif
#if ENVIRONMENT != ENVIRONMENT_NONE
    if (lane_any(lit & environment)) le = l3_select(le, environment_radiance_at(scene, env_uv), environment);
#endif
    lane_float weight = select(power_heuristic(light_pdf_w, bsdf_pdf_w * bsdf_share), (lane_float)(1.0f), delta);
    return l3_select(radiance, l3_scale(l3_mul(f, le), weight / light_pdf_w), lit);
}

// The scattering of the lanes' vertices (bsdf.h, sample_bsdf_with): the diffuse lobe; where
// `smooth`, the smooth dielectric's pair of delta lobes, or where also `conductor` the
// conductor's mirror; where glossy->rough or glossy->plastic, the glossy lobes
// (sample_glossy_lanes); a lobe picked with u_lobe, the direction drawn with u.
BsdfSample sample_bsdf_lanes(const Scene* scene, const SurfacePoint* sp, lane_float3 color, lane_float3 wo,
                             lane_int smooth, lane_int conductor, const GlossyLanes* glossy, lane_float u_lobe,
                             lane_float2 u, lane_int lanes) {
    BsdfSample bs = bsdf_sample_none();
    bs.wi = sample_diffuse(scene, sp, u, &bs.pdf_w);
    // For cosine sampling f * cos / pdf is the albedo itself.
    bs.weight = l3_select(l3_splat(0.0f), color, bs.pdf_w > 0.0f);
    if (scene->params->guide_cells.w != 0)   // the guide's mixture (materials/diffuse.h)
        bs.weight = l3_select(l3_splat(0.0f), l3_div(eval_diffuse(color, sp, bs.wi), bs.pdf_w), bs.pdf_w > 0.0f);
#if DIELECTRIC
    lane_int glossy_lanes = (glossy->rough | glossy->plastic) & lanes;
    if (lane_any(glossy_lanes)) {
        BsdfSample glossy_bs = sample_glossy_lanes(glossy, sp, wo, u_lobe, u, glossy_lanes);
        bs.wi = l3_select(bs.wi, glossy_bs.wi, glossy_lanes);
        bs.pdf_w = select(bs.pdf_w, glossy_bs.pdf_w, glossy_lanes);
        bs.weight = l3_select(bs.weight, glossy_bs.weight, glossy_lanes);
        bs.eta = select(bs.eta, glossy_bs.eta, glossy_lanes);
        bs.delta = select(bs.delta, glossy_bs.delta, glossy_lanes);   // plastic's mirror
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
    bs.delta |= smooth;
#endif
    return bs;
}

// What the lanes' vertices scatter with: smooth dielectrics and conductors (delta lobes; where
// `conductor` a mirror), glossy lobes (rough ones and plastic), else diffuse of `color`. A
// one-sided material seen from behind is black (bsdf.h, is_one_sided_back): no light reaches it,
// and a path ends there.
typedef struct {
    lane_int conductor, black_back, smooth;
    lane_float3 color;
    GlossyLanes glossy;
} SurfaceLanes;

SurfaceLanes surface_lanes(const Scene* scene, const LaneHit* hit, const SurfacePoint* sp, lane_float3 wo,
                           lane_int alive) {
    SurfaceLanes s;
    lane_int kind = material_kind_at(scene->materials, sp->material);
    s.conductor = kind == MATERIAL_CONDUCTOR;
    s.black_back = (material_one_sided_at(scene->materials, sp->material) != 0) & !sp->front_face;
    s.color = l3_select(surface_color_lanes(scene, hit, sp->material, alive), l3_splat(0.0f), s.black_back);
    s.glossy = glossy_lanes(scene, sp, kind, s.color, s.black_back, wo);
    s.smooth = ((kind == MATERIAL_DIELECTRIC) | s.conductor) & !s.glossy.rough;
    return s;
}

// The sample-level AOVs of the lanes' paths (aovs.h, AovSample): those of the first non-delta
// vertex or of the escape (aov_record_escapes); a path that ends before either records zeros.
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

#if ENVIRONMENT != ENVIRONMENT_NONE
// aovs.h, aov_record_escape, at the escaping rays of `lanes` that record nothing yet; `visible`:
// whether they see the environment (not camera rays where it is hidden from them). (Without an
// environment an escape records zeros, as the lanes start.)
void aov_record_escapes(const Scene* scene, AovLanes* aov, lane_float3 dir, lane_float3 throughput,
                        lane_float eta_scale, bool visible, lane_int lanes) {
    lanes &= !aov->found;
    if (!AOVS || !lane_any(lanes)) return;
    lane_float3 le = visible ? environment_radiance(scene, dir) : l3_splat(0.0f);
    lane_float3 filter = make_lane_float3(clamp(throughput.x * eta_scale, 0.0f, 1.0f),
                                          clamp(throughput.y * eta_scale, 0.0f, 1.0f),
                                          clamp(throughput.z * eta_scale, 0.0f, 1.0f));
    aov->albedo = l3_select(aov->albedo, l3_mul(filter, l3_scale(le, 1.0f / fmax(max_component(le), 1.0f))), lanes);
    aov->normal = l3_select(aov->normal, l3_splat(0.0f), lanes);
    aov->emission = l3_select(aov->emission, l3_mul(throughput, le), lanes);
    aov->found |= lanes;
}
#endif

#if TEXTURES
// Mitsuba's masks as path.h crosses them (materials/mask.h): a lane whose ray stops at a masked
// surface draws a number there (where the opacity is below 1; the other lanes give it back) and
// passes with probability 1 - opacity, after the surface's emission and at the same depth (no
// vertex, no AOVs): its ray goes on from there, until every lane's ray stops at a surface or
// escapes. Returns the lanes stopped at a surface; *ended gets those that crossed more than
// MAX_NULL_CROSSINGS surfaces (*crossings: per lane, over the path), ended there as in path.h.
lane_int cross_masks(const Scene* scene, Ray* ray, lane_int alive, LaneHit* hit, lane_float3* radiance,
                     lane_float3 throughput, lane_float3 prev_p, lane_float prev_pdf_w, lane_int prev_delta,
                     lane_int* crossings, lane_int* ended, Rng* rng) {
    // The lanes whose ray has just stopped at a surface not yet looked at: all, then those that passed.
    for (lane_int arrived = alive;;) {
        lane_int material = LANE_LOAD_INT(scene->info, hit->prim, .info.x);
        lane_int masked = arrived & material_masked_at(scene->materials, material);
        if (!lane_any(masked)) return alive;
        lane_float opacity = surface_opacity_lanes(scene, hit, material, masked);
        lane_int draws = masked & (opacity < 1.0f);
        if (!lane_any(draws)) return alive;
        lane_float u = rng_float(rng);
        rng->counter -= select((lane_uint)(1u), (lane_uint)(0u), draws);
        lane_int passing = draws & (u >= opacity);
        if (!lane_any(passing)) return alive;
        SurfacePoint sp = surface_point(scene, hit, ray->direction);
        lane_float3 emitted = emitted_radiance_lanes(scene, &sp, prev_p, ray->direction, prev_pdf_w, prev_delta);
        *radiance = l3_select(*radiance, l3_add(*radiance, l3_mul(throughput, emitted)), passing);
        *crossings += select((lane_int)(0), (lane_int)(1), passing);
        lane_int over = passing & (*crossings > MAX_NULL_CROSSINGS);
        *ended |= over;
        alive &= !over;
        passing &= !over;
        ray->origin = l3_select(ray->origin, spawn_ray_origin(&sp, ray->direction), passing);
        LaneHit beyond;
        lane_int found = closest_hits(scene, ray->origin, ray->direction, INFINITY, passing, &beyond);
        alive &= !passing | found;
        arrived = passing & found;
        hit->t = select(hit->t, beyond.t, passing);
        hit->b1 = select(hit->b1, beyond.b1, passing);
        hit->b2 = select(hit->b2, beyond.b2, passing);
        hit->prim = select(hit->prim, beyond.prim, passing);
        hit->block_lane = select(hit->block_lane, beyond.block_lane, passing);
        hit->sphere = select(hit->sphere, beyond.sphere, passing);
        hit->from_centre = l3_select(hit->from_centre, beyond.from_centre, passing);
    }
}
#endif

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
#if TEXTURES
    lane_int crossings = 0;            // masks passed (path.h's null_crossings)
#endif
    CausticEvents events = caustic_events_none();
    for (int depth = 1; depth <= max_depth; ++depth) {
        LaneHit hit;
        lane_int escaped = alive;
        alive = depth == 1 ? closest_camera_hits(scene, ray.origin, ray.direction, alive, &hit)
                           : closest_hits(scene, ray.origin, ray.direction, INFINITY, alive, &hit);
#if TEXTURES
        lane_int ended = 0;
        alive = cross_masks(scene, &ray, alive, &hit, &radiance, throughput, prev_p, prev_pdf_w, prev_delta,
                            &crossings, &ended, rng);
        escaped &= !ended;
#endif
#if ENVIRONMENT != ENVIRONMENT_NONE
        escaped &= !alive;
        if (lane_any(escaped)) {
            // As path.h: camera rays do not see a hidden environment (it still lights the scene).
            bool visible = depth > 1 || (scene->params->environment.w & HIDE_ENVIRONMENT) == 0;
            aov_record_escapes(scene, aov, ray.direction, throughput, eta_scale, visible, escaped);
            if (visible) {
                lane_float3 le = escaped_radiance(scene, ray.direction, prev_pdf_w, prev_delta);
                radiance = l3_select(radiance, l3_add(radiance, l3_mul(throughput, le)), escaped);
            }
        }
#endif
        if (!lane_any(alive)) break;
        SurfacePoint sp = surface_point(scene, &hit, ray.direction);
        lane_float3 wo = l3_neg(ray.direction);
        SurfaceLanes surface = surface_lanes(scene, &hit, &sp, wo, alive);
        lane_int conductor = surface.conductor, black_back = surface.black_back, smooth = surface.smooth;
        lane_float3 color = surface.color;
        GlossyLanes glossy = surface.glossy;
        aov_record_surfaces(scene, aov, &sp, color, throughput, eta_scale, alive & !smooth);
        lane_float3 emitted = emitted_radiance_lanes(scene, &sp, prev_p, ray.direction, prev_pdf_w, prev_delta);
        radiance = l3_select(radiance, l3_add(radiance, l3_mul(throughput, emitted)),
                             alive & !light_paths_take(scene, &events, sp.emitter));
        if (depth == max_depth) break;
        // The vertex's numbers, as path.h draws them (a smooth vertex leaves its light sample's unused).
        VertexNumbers u = draw_vertex_numbers(rng);
        // The camera hits' shadow rays as one packet where no surface can be a mask: masks (a
        // TEXTURES feature) read which surface blocks a ray, and that depends on the packet.
#if TEXTURES
        bool coherent_shadows = false;
#else
        bool coherent_shadows = depth == 1;
#endif
        lane_float3 direct = direct_light_lanes(scene, &sp, color, &glossy, wo, u.light, alive & !smooth, 1.0f,
                                                coherent_shadows);
        // Selected, not added everywhere: the throughput of a finished lane may be anything.
        radiance = l3_select(radiance, l3_add(radiance, l3_mul(throughput, direct)), alive);
        BsdfSample bs = sample_bsdf_lanes(scene, &sp, color, wo, smooth, conductor, &glossy, u.choice.x, u.direction,
                                          alive);
        alive &= (bs.pdf_w > 0.0f) & !is_black(bs.weight) & !black_back;
        throughput = l3_mul(throughput, bs.weight);
        caustic_events_add(&events, depth, bs.delta);
        prev_pdf_w = bs.pdf_w;
        prev_delta = bs.delta;
        prev_p = sp.p;
        eta_scale *= bs.eta * bs.eta;
        ray.origin = spawn_ray_origin(&sp, bs.wi);
        ray.direction = bs.wi;
        if (depth >= rr_depth) {
            // path.h, survive_roulette
            lane_float survive = fmin(max_component(throughput) * eta_scale, 0.95f);
            alive &= u.choice.y < survive;
            throughput = l3_div(throughput, survive);
        }
        if (!lane_any(alive)) break;
    }
    return radiance;
}

#endif
