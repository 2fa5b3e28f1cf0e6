// Light transport through media shared by every estimator: the transmittance of shadow rays
// through index-matched boundaries, masks and any media (shadow_ray: plain visibility in a kernel
// without media or masks), and next-event estimation at a scattering vertex inside a medium.
// Built on media/medium.h only, and included by path.h and materials/toon.h before they use it
// (no estimator calls back into the integrator).
#ifndef CLRENDER_TRANSPORT_H
#define CLRENDER_TRANSPORT_H
#include "scene.h"
#include "lights.h"
#include "sampling.h"
#include "materials/material.h"
#include "materials/textured_params.h"
#include "materials/mask.h"
#include "media/medium.h"

#if MEDIA || TEXTURES
// The fraction of light a surface lets a shadow ray through: an index-matched boundary's
// colour, a mask's 1 - opacity; 0 for anything else.
float3 surface_transmittance(const Material* m) {
#if MEDIA
    if (material_is_interface(m)) return material_boundary_transmittance(m);
#endif
#if TEXTURES
    return (float3)(mask_transmittance(m));
#else
    return (float3)(0.0f);
#endif
}

// Transmittance from origin towards a light dist away (INFINITY for distant lights) through
// index-matched boundaries (times their colour), masks (times 1 - opacity) and the media
// between them; 0 when anything else blocks it.
// *pdf_ratio: the product of the segments' transmittance pdf ratios, unidirectional over light
// technique (media/medium.h), by which MIS multiplies the other technique's directional pdf.
float3 shadow_transmittance(const Scene* scene, float3 origin, float3 dir, float dist, int medium,
                            Rng* rng, float* pdf_ratio) {
    float3 tr = (float3)(1.0f);
    float3 target = origin + dir * dist;
    *pdf_ratio = 1.0f;
    for (int crossing = 0; crossing < MAX_NULL_CROSSINGS; ++crossing) {
        float remaining = isinf(dist) ? INFINITY : dot(target - origin, dir);
        Hit hit;
        // Stop short of the light's own surface by a relative margin, valid at every scene scale.
        bool found = intersect_scene(scene, origin, dir, remaining * (1.0f - 1e-4f), &hit);
#if MEDIA
        if (medium >= 0) {
            float ratio;
            tr *= medium_transmittance(scene, medium, origin, dir, found ? hit.t : remaining, rng, &ratio);
            *pdf_ratio *= ratio;
            if (is_black(tr)) return tr;
        }
#endif
        if (!found) return tr;
        SurfacePoint sp = surface_point(scene, &hit, dir);
        Material m = surface_material(scene, &sp);
        tr *= surface_transmittance(&m);
        if (is_black(tr)) return tr;
#if MEDIA
        medium = medium_beyond(&sp);
#endif
        origin = spawn_ray_origin(&sp, dir);
    }
    return (float3)(0.0f);
}
#endif

#if MEDIA
// Next-event estimation from a scattering vertex p inside a medium; dir: the incoming travel
// direction. mis: whether phase sampling may also reach the light from here (not so when the
// path ends at this vertex: medium_scatters_once), else the light sample has full weight.
float3 direct_light_in_medium(const Scene* scene, float3 p, float3 dir, int medium, bool mis, Rng* rng) {
    LightSample ls = sample_light(scene, p, rng_float2(rng));
    if (!(ls.pdf_w > 0.0f) || is_black(ls.radiance)) return (float3)(0.0f);
    float phase = eval_medium_phase(scene, medium, dir, ls.wi);
    float pdf_ratio;
    float3 tr = shadow_transmittance(scene, p, ls.wi, ls.dist, medium, rng, &pdf_ratio);
    if (is_black(tr)) return (float3)(0.0f);
    float weight = (ls.delta || !mis) ? 1.0f : power_heuristic(ls.pdf_w, phase * pdf_ratio);
    return tr * light_sample_radiance(scene, &ls) * (phase * weight / ls.pdf_w);
}
#endif

// Fraction of light arriving along a shadow ray: 0/1 visibility, or transmittance with media or
// masks (*pdf_ratio: see shadow_transmittance; 1 without media).
float3 shadow_ray(const Scene* scene, float3 origin, float3 dir, float dist, int medium, Rng* rng,
                  float* pdf_ratio) {
    *pdf_ratio = 1.0f;
#if MEDIA
    return shadow_transmittance(scene, origin, dir, dist, medium, rng, pdf_ratio);
#else
    // Stop short of the light's own surface by a relative margin, valid at every scene scale.
    int blocker = occluder(scene, origin, dir, dist * (1.0f - 1e-4f));
    if (blocker < 0) return (float3)(1.0f);
#if TEXTURES
    // Any blocker ends an unmasked shadow ray, as before; a mask needs the surfaces in order.
    if (material_masked_at(scene->materials, scene->info[blocker].info.x))
        return shadow_transmittance(scene, origin, dir, dist, medium, rng, pdf_ratio);
#endif
    return (float3)(0.0f);
#endif
}

#endif
