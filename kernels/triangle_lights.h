// Emitting triangles as lights, over the lane types (lanes.h): points sampled uniformly by area,
// and the solid-angle density of reaching them.
#ifndef CLRENDER_TRIANGLE_LIGHTS_H
#define CLRENDER_TRIANGLE_LIGHTS_H
#include "lanes.h"
#include "types.h"
#include "math.h"
#include "sampling.h"
#include "scene.h"

// Solid-angle pdf of reaching a point on an emitting triangle of this area, given the distance
// and cosine.
lane_float triangle_emitter_pdf_w(lane_float area, lane_float dist, lane_float cos_light) {
    return select((lane_float)(0.0f), dist * dist / (cos_light * area), cos_light > 0.0f);
}

// A point q on emitting triangle `index` (Emitter: p0, e1, e2, area in p0.w), uniform by area:
// the unit direction from p to q, with *dist = |q - p| (not > 0: no sample) and *pdf_w the
// solid-angle density of that direction (not including the emitter's selection probability).
lane_float3 sample_triangle_emitter(const Scene* scene, lane_int index, lane_float3 p, lane_float2 u,
                                    lane_float* dist, lane_float* pdf_w) {
    lane_float3 p0 = LANE_LOAD3(scene->emitters, index, .p0);
    lane_float3 e1 = LANE_LOAD3(scene->emitters, index, .e1);
    lane_float3 e2 = LANE_LOAD3(scene->emitters, index, .e2);
    lane_float2 b = sample_triangle(u);
    lane_float3 n_light = l3_normalize(l3_cross(e1, e2));
    lane_float3 q = l3_add(l3_add(p0, l3_scale(e1, b.x)), l3_scale(e2, b.y));
    // q is off the light's plane by up to its rounding error, which far from the origin
    // exceeds the shadow ray's relative margin: move it off the plane towards p by that
    // bound (as spawned rays are, scene.h), so the shadow ray stops before the light.
    lane_float3 magnitude = l3_add(l3_add(l3_abs(p0), l3_abs(e1)), l3_abs(e2));
    q = offset_ray_origin(q, l3_select(l3_neg(n_light), n_light, l3_dot(l3_sub(p, q), n_light) > 0.0f),
                          SURFACE_ERROR_EPS * l3_dot(l3_abs(n_light), magnitude));
    lane_float3 d = l3_sub(q, p);
    *dist = l3_length(d);
    lane_float3 wi = l3_div(d, *dist);
    *pdf_w = triangle_emitter_pdf_w(LANE_LOAD(scene->emitters, index, .p0.w), *dist, -l3_dot(wi, n_light));
    return wi;
}

#endif
