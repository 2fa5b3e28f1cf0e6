// Mitsuba 3.9's `bumpmap` and `normalmap` (TEXTURES=1): the shading normal bent at a hit before
// any BSDF reads it (ray offsets and the BSDFs' leak guards keep the geometric normal), and the
// factor Mitsuba applies around the BSDF. Both maps act on the front side's frame, as Mitsuba's
// (its sh_frame: n the interpolated normal, s along dp/du), and the result is turned to the side
// the ray came from, as ns is; seen from behind, the surface is the same bumpy one (Mitsuba's
// bumpmap outside twosided).
#ifndef CLRENDER_SHADING_MAPS_H
#define CLRENDER_SHADING_MAPS_H
#include "math.h"
#include "scene.h"
#include "materials/material.h"
#include "textures/texture.h"

#if TEXTURES
bool has_shading_map(const Material* m) {
    return material_bump_map(m) >= 0 || material_normal_map(m) >= 0;
}

// The surface displaced by the bump map's height along its front shading normal n (dp/du and
// dp/dv gain the height's gradient along n, their own component along n dropped): the normal
// of the tangent plane they span, on the side of the front geometric normal ng; not normalised.
// The height is in world lengths: bump_scale holds the device's length scale (arrays.py).
float3 bump_mapped_normal(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 n, float3 ng) {
    float2 g = material_bump_scale(m) * eval_texture_number_gradient(scene, material_bump_map(m), sp->uv);
    float3 dpdu = sp->dpdu + n * (g.x - dot(n, sp->dpdu));
    float3 dpdv = sp->dpdv + n * (g.y - dot(n, sp->dpdv));
    float3 b = cross(dpdu, dpdv);
    return dot(b, ng) < 0.0f ? -b : b;
}

// The normal map's RGB in [0, 1] as a direction 2 rgb - 1 in the front shading frame (s along
// dp/du, t = n x s, n); not normalised.
float3 normal_mapped_normal(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 n) {
    float3 s = normalize(sp->dpdu - n * dot(n, sp->dpdu));
    float3 c = 2.0f * eval_texture(scene, material_normal_map(m), sp->uv) - 1.0f;
    return c.x * s + c.y * cross(n, s) + c.z * n;
}

// Bends sp->ns by the material's map, seen from wo (towards the viewer); keeps the unbent
// normal in sp->ns_unbent. Where wo lies on different sides of the bent and the unbent normal,
// the bent one's tangential part is mirrored (Schuessler et al. 2017, Mitsuba's
// flip_invalid_normals); a bent normal that cannot be normalised leaves ns as it was.
void bend_shading_normal(const Scene* scene, const Material* m, SurfacePoint* sp, float3 wo) {
    sp->ns_unbent = sp->ns;
    if (!has_shading_map(m)) return;
    float3 n = sp->front_face ? sp->ns : -sp->ns;
    float3 ng = sp->front_face ? sp->ng : -sp->ng;
    float3 bent = material_bump_map(m) >= 0 ? bump_mapped_normal(scene, m, sp, n, ng)
                                            : normal_mapped_normal(scene, m, sp, n);
    if (!sp->front_face) bent = -bent;
    if (dot(wo, sp->ns) * dot(wo, bent) <= 0.0f) bent = 2.0f * dot(bent, sp->ns) * sp->ns - bent;
    float len = length(bent);
    if (len > 0.0f && isfinite(len)) sp->ns = bent / len;
}

// tan^2 of the angle between unit vectors whose cosine is c.
float tan2_from_cos(float c) { return fmax(1.0f - c * c, 0.0f) / (c * c); }
#endif

// What Mitsuba's bumpmap and normalmap multiply their BSDF's value (and a sample's weight) by,
// for the direction wi it was evaluated or sampled in: 0 unless wi lies on the same side of the
// bent and the unbent normal, else the shadowing function of Conty Estevez et al., "A
// Microfacet-Based Shadowing Function to Solve the Bump Terminator Problem" (Ray Tracing Gems,
// 2019; Mitsuba's use_shadowing_function), which softens the terminator of bent normals. 1 for a
// material without a map.
float shading_map_factor(const Material* m, const SurfacePoint* sp, float3 wi) {
#if TEXTURES
    if (!has_shading_map(m)) return 1.0f;
    float cos_unbent = dot(wi, sp->ns_unbent);
    if (!(cos_unbent * dot(wi, sp->ns) > 0.0f)) return 0.0f;
    float alpha2 = fmin(0.125f * tan2_from_cos(dot(sp->ns, sp->ns_unbent)), 1.0f);
    return 2.0f / (1.0f + sqrt(1.0f + alpha2 * tan2_from_cos(cos_unbent)));
#else
    return 1.0f;
#endif
}

#endif
