// Lambertian reflection. eval_* return f * |cos|, sample_* draw wi, *_pdf give pdf_w.
#ifndef CLRENDER_DIFFUSE_H
#define CLRENDER_DIFFUSE_H
#include "math.h"
#include "sampling.h"
#include "scene.h"

lane_float3 eval_diffuse(lane_float3 albedo, const SurfacePoint* sp, lane_float3 wi) {
    // Both normals must agree, or light leaks through the geometric surface.
    lane_float3 f = l3_scale(albedo, (fmax(l3_dot(sp->ns, wi), 0.0f) * INV_PI_F));
    return l3_select(f, l3_splat(0.0f), l3_dot(sp->ng, wi) <= 0.0f);
}

lane_float sample_diffuse_pdf(const SurfacePoint* sp, lane_float3 wi) {
    return select(sample_cosine_hemisphere_pdf_w(l3_dot(sp->ns, wi)), (lane_float)(0.0f), l3_dot(sp->ng, wi) <= 0.0f);
}

lane_float3 sample_diffuse(const SurfacePoint* sp, lane_float2 u) {
    return to_world(sample_cosine_hemisphere(u), sp->ns);
}

#endif
