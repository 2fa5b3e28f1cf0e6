// Lambertian reflection. eval_* return f * |cos|, sample_* draw wi, *_pdf give pdf_w.
#ifndef CLRENDER_DIFFUSE_H
#define CLRENDER_DIFFUSE_H
#include "math.h"
#include "sampling.h"
#include "scene.h"

float3 eval_diffuse(float3 albedo, const SurfacePoint* sp, float3 wi) {
    // Both normals must agree, or light leaks through the geometric surface.
    if (dot(sp->ng, wi) <= 0.0f) return (float3)(0.0f);
    return albedo * (fmax(dot(sp->ns, wi), 0.0f) * INV_PI_F);
}

float sample_diffuse_pdf(const SurfacePoint* sp, float3 wi) {
    if (dot(sp->ng, wi) <= 0.0f) return 0.0f;
    return sample_cosine_hemisphere_pdf_w(dot(sp->ns, wi));
}

float3 sample_diffuse(const SurfacePoint* sp, float2 u) {
    return to_world(sample_cosine_hemisphere(u), sp->ns);
}

#endif
