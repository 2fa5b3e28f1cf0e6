// A thin dielectric sheet (window panes, soap films; Mitsuba 3's thindielectric): two parallel
// interfaces so close that a ray leaves where it entered. Light reflects with the Fresnel
// reflectance of the sheet summed over its internal reflections, R' = R + T^2 R / (1 - R^2),
// or passes straight through (wi = -wo) with the rest, T' = 1 - R'; the indices on both sides
// are the same, so a crossing ray keeps its radiance (no eta^2). A pair of delta lobes, picked
// with probabilities R' and T', each weighing its tint (specular_reflectance,
// specular_transmittance). Conventions as in dielectric.h.
#ifndef CLRENDER_THIN_DIELECTRIC_H
#define CLRENDER_THIN_DIELECTRIC_H
#include "math.h"
#include "materials/bsdf_sample.h"
#include "materials/dielectric_smooth.h"
#if DIELECTRIC

// R' of the sheet at |cos_i|, eta the index of the sheet over its surroundings (either way up:
// the sum is the same seen from both sides). Total internal reflection (an eta < 1 sheet)
// reflects everything.
float thin_dielectric_reflectance(float cos_i, float eta) {
    float r = fresnel_dielectric(fabs(cos_i), eta);
    float t = 1.0f - r;
    return r < 1.0f ? r + t * t * r / (1.0f - r * r) : r;
}

// ng: the geometric normal on wo's side; as for conductors, the facet's mirror direction
// replaces one that an interpolated normal sends into the surface.
BsdfSample sample_thin_dielectric(float3 reflect_tint, float3 tint, float eta, float3 n, float3 ng,
                                  float3 wo, float rnl) {
    BsdfSample bs = bsdf_sample_none();
    bs.delta = true;
    float r = thin_dielectric_reflectance(dot(n, wo), eta);
    if (rnl < r) {
        bs.wi = reflect(wo, n);
        if (dot(bs.wi, ng) <= 0.0f) bs.wi = reflect(wo, ng);
        bs.weight = reflect_tint;
        bs.pdf_w = r;
    } else {
        bs.wi = -wo;
        bs.weight = tint;
        bs.pdf_w = 1.0f - r;
    }
    return bs;
}

#endif
#endif
