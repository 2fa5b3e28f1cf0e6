// Lambertian reflection. eval_* return f * |cos|, sample_* draw wi, *_pdf give pdf_w. Sampling
// follows the cosine, or where the scene has a caustic guide (guide.h) a mixture of the cosine
// and the guide's cones of the cell the point lies in.
#ifndef CLRENDER_DIFFUSE_H
#define CLRENDER_DIFFUSE_H
#include "math.h"
#include "sampling.h"
#include "scene.h"
#include "guide.h"

lane_float3 eval_diffuse(lane_float3 albedo, const SurfacePoint* sp, lane_float3 wi) {
    // Both normals must agree, or light leaks through the geometric surface.
    lane_float3 f = l3_scale(albedo, (fmax(l3_dot(sp->ns, wi), 0.0f) * INV_PI_F));
    return l3_select(f, l3_splat(0.0f), l3_dot(sp->ng, wi) <= 0.0f);
}

// The first lobe of sp's guide cell (guide_cell_lobes), -1 without a guide there.
lane_int diffuse_guide_cell(const Scene* scene, const SurfacePoint* sp) {
    return scene->params->guide_cells.w != 0 ? guide_cell_lobes(scene, sp->p) : (lane_int)(-1);
}

// The guide's share of the samples in the cell whose lobes start at `first` (-1: none).
lane_float diffuse_guide_share(const Scene* scene, lane_int first) {
    return select((lane_float)(0.0f), (lane_float)(scene->params->guide_cone.x), first >= 0);
}

// The density of wi at sp, whose guide cell's lobes start at `first` (-1: none).
lane_float diffuse_pdf_in_cell(const Scene* scene, const SurfacePoint* sp, lane_int first, lane_float3 wi) {
    lane_float pdf = sample_cosine_hemisphere_pdf_w(l3_dot(sp->ns, wi));
    if (lane_any(first >= 0)) {
        lane_float share = diffuse_guide_share(scene, first);
        pdf = (1.0f - share) * pdf + share * guide_pdf_w(scene, first, wi);
    }
    return select(pdf, (lane_float)(0.0f), l3_dot(sp->ng, wi) <= 0.0f);
}

lane_float sample_diffuse_pdf(const Scene* scene, const SurfacePoint* sp, lane_float3 wi) {
    return diffuse_pdf_in_cell(scene, sp, diffuse_guide_cell(scene, sp), wi);
}

// A direction and (*pdf_w) its density.
lane_float3 sample_diffuse(const Scene* scene, const SurfacePoint* sp, lane_float2 u, lane_float* pdf_w) {
    lane_int first = diffuse_guide_cell(scene, sp);
    lane_float share = diffuse_guide_share(scene, first);
    lane_int guided = u.x < share;
    // u.x beyond the guide's share, stretched over [0, 1) again for the cosine (u.x itself
    // where the share is 0).
    lane_float2 u_cosine = make_lane_float2(fmin((u.x - share) / (1.0f - share), 0.99999994f), u.y);
    lane_float3 wi = to_world(sample_cosine_hemisphere(u_cosine), sp->ns);
    if (lane_any(guided))
        wi = l3_select(wi, sample_guide(scene, first, make_lane_float2(u.x / share, u.y)), guided);
    *pdf_w = diffuse_pdf_in_cell(scene, sp, first, wi);
    return wi;
}

#endif
