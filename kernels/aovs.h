// Sample-level auxiliary outputs (AOVS=1): the albedo and shading normal a denoiser wants (Intel
// Open Image Denoise's definitions), the emission seen directly and the sum of squared deviations
// of the colour samples, all
// accumulated per pixel beside the colour, sample by sample in index order, so they are averaged
// (anti-aliased) like the colour and bit-identical however the samples are split into launches.
// (Depth and object id come from the pixel-centre ray instead: aux_buffers.h.)
//
// The albedo and normal of a sample are those of its path's first non-delta vertex: the camera
// path follows smooth mirrors, smooth glass and index-matched surfaces, so a reflection or the
// object behind a window keeps its own albedo and normal, picked in proportion to Fresnel as the
// path picks its lobe (OIDN's "Fresnel blend of the reflected and transmitted albedos").
//   albedo = filter * colour of the vertex, where filter is the path throughput up to the vertex
//   without the eta^2 radiance scaling of refraction, clamped to [0, 1] (the tints of the glass and
//   mirrors passed, the transmittance of media crossed), and the colour is
//     diffuse: its albedo; toon, principled: its base colour; rough dielectric: its tint (1 for
//     clear glass);
//     rough conductor: its reflectance (the colour at normal incidence);
//     the front face of an emitter: its emission, scaled down to a maximum component of 1 when
//       brighter (its hue; OIDN wants albedos in [0, 1]);
//     the back of a one-sided material: 0 (it is black);
//     a scattering point in a medium: its single-scattering albedo sigma_s / sigma_t there (the
//       same at any density of a grid medium, unless it has an albedo grid);
//     an escaped ray: the environment's radiance scaled like an emitter's (0 without one, and
//       for camera rays when the environment is hidden from them).
//   normal = the unit shading normal on the side the path arrived from (facing the camera for
//   the first surface); 0 at medium scattering points and for escaped rays, which have no
//   surface. A sample whose path ends before any such vertex (depth or roulette in a chain of
//   mirrors) adds albedo 0 and normal 0.
//   emission = the part of the sample's colour that the vertex emits towards the camera: an
//   emitter's front face or the environment, seen directly or through mirrors and glass (times
//   their filter, eta^2 scaling included: exactly the term the colour adds there). It is exact
//   (no lighting noise, only the pixel coverage and the Fresnel choice), so the denoiser leaves it
//   out (clrender/denoise.py). 0 at medium scattering points.
// Ray marching without multiple scattering ends a path at its first scattering vertex in a grid
// medium (after its light sample): that vertex is recorded like any other.
#ifndef CLRENDER_AOVS_H
#define CLRENDER_AOVS_H

#include "types.h"
#include "math.h"
#include "aov_sums.h"
#include "scene.h"
#include "lights.h"
#include "materials/material.h"
#include "materials/bsdf.h"
#include "media/medium.h"

// What one path sample records (filled at most once, by the first non-delta vertex).
typedef struct {
    float3 albedo;
    float3 normal;
    float3 emission;
    bool found;
} AovSample;

AovSample aov_sample_none(void) {
    AovSample aov;
    aov.albedo = (float3)(0.0f);
    aov.normal = (float3)(0.0f);
    aov.emission = (float3)(0.0f);
    aov.found = false;
    return aov;
}

// The recording functions below compile to nothing without AOVS, so trace_path calls them
// unconditionally.

// A radiance seen as a colour: scaled into [0, 1] when brighter, keeping its hue.
float3 emission_albedo(float3 le) { return le / fmax(max_component(le), 1.0f); }

// The filter of the albedo: the throughput without eta^2 scaling, clamped to [0, 1].
float3 aov_filter(float3 throughput, float eta_scale) {
    return clamp(throughput * eta_scale, 0.0f, 1.0f);
}

void aov_record(AovSample* aov, float3 albedo, float3 normal, float3 emission) {
    aov->albedo = albedo;
    aov->normal = normal;
    aov->emission = emission;
    aov->found = true;
}

// A surface vertex with a non-delta material; throughput and eta_scale as in trace_path. Every
// vertex before it was delta, so the colour adds its emission with full weight (no MIS).
void aov_record_surface(AovSample* aov, const Material* m, const SurfacePoint* sp, float3 throughput,
                        float eta_scale) {
    if (!AOVS || aov->found) return;
    bool emits = sp->front_face && sp->emitter >= 0;
    float3 emission = material_emission(m);
    float3 colour = emits ? emission_albedo(emission)
                          : (is_one_sided_back(m, sp) ? (float3)(0.0f) : material_color(m));
    aov_record(aov, aov_filter(throughput, eta_scale) * colour, sp->ns,
               emits ? throughput * emission : (float3)(0.0f));
}

#if MEDIA
// A real scattering event at p in a medium.
void aov_record_medium(AovSample* aov, const Scene* scene, int medium, float3 p, float3 throughput,
                       float eta_scale) {
    if (!AOVS || aov->found) return;
    aov_record(aov, aov_filter(throughput, eta_scale) * medium_albedo(scene, medium, p), (float3)(0.0f),
               (float3)(0.0f));
}
#endif

// A ray leaving the scene; `visible`: whether the colour shows the environment there (not to
// camera rays when it is hidden from them).
void aov_record_escape(AovSample* aov, const Scene* scene, float3 dir, float3 throughput, float eta_scale,
                       bool visible) {
    if (!AOVS || aov->found) return;
    float3 le = (float3)(0.0f);
#if ENVIRONMENT != ENVIRONMENT_NONE
    if (visible) le = environment_radiance(scene, dir);
#endif
    aov_record(aov, aov_filter(throughput, eta_scale) * emission_albedo(le), (float3)(0.0f), throughput * le);
}

// The sample's AOVs weighted as its colour is (the pixel filter's weight, filter.h), so that
// they are filtered alike.
void aov_weight(AovSample* aov, float weight) {
    aov->albedo *= weight;
    aov->normal *= weight;
    aov->emission *= weight;
}

// Adds one sample to the pixel's sums (aov_sums.h); a non-finite sample counts as black in the
// colour, so its emission does too.
#if AOVS
void accumulate_aovs(AovSums* sums, const AovSample* aov, float3 value, bool finite, float4 sum) {
    add_sample_aovs(sums, aov->albedo, aov->normal, finite ? aov->emission : (float3)(0.0f), value, sum);
}

// With sample items (integrator.cl): the sample's AOVs as the record of the pass's `index`-th
// sample of the pixel in `slot`, which sum_samples (splat.cl) adds in sample order with the
// colour's deviations (those it computes from the radiance record).
void write_sample_aovs(__constant RenderParams* params, __global AovSums* records, int index, int slot,
                       const AovSample* aov, bool finite) {
    AovSums record;
    record.albedo = (float4)(aov->albedo, 0.0f);
    record.normal = (float4)(aov->normal, 0.0f);
    record.emission = (float4)(finite ? aov->emission : (float3)(0.0f), 0.0f);
    record.colour_m2 = (float4)(0.0f);
    records[index * params->tile.z * params->tile.w + slot] = record;
}
#endif

#endif
