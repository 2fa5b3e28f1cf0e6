// Emitting spheres as lights, and the density of reaching a point on either kind of area emitter
// (spheres and triangles: triangle_lights.h), over the lane types (lanes.h).
//
// Seen from outside, a sphere fills a cone of directions; it is sampled uniformly inside that
// cone (pbrt-v4, Sphere::Sample), so the pdf is 1 / (2 pi (1 - cos theta_max)) wherever it is
// seen. A flipped sphere (front face, and so its emission, inside) is seen from inside only: it
// is sampled uniformly by area. From anywhere else only back faces are seen, which do not emit.
#ifndef CLRENDER_AREA_LIGHTS_H
#define CLRENDER_AREA_LIGHTS_H
#include "lanes.h"
#include "types.h"
#include "math.h"
#include "sampling.h"
#include "scene.h"
#include "sphere.h"
#include "triangle_lights.h"

// Below sin^2 theta_max = sin^2(1.5 degrees), 1 - cos theta_max is its Taylor term (pbrt-v4):
// the subtraction would cancel.
#define SMALL_CONE_SIN2 0.00068523f

lane_float sphere_cone_one_minus_cos(lane_float sin2_max) {
    return select(1.0f - sqrt(fmax(0.0f, 1.0f - sin2_max)), 0.5f * sin2_max, sin2_max < SMALL_CONE_SIN2);
}

// Solid-angle pdf of sampling the direction from p to q on emitting sphere `index`; cos_light:
// the cosine at q between the sphere's front normal and the direction back to p.
lane_float sphere_emitter_pdf_w(__global const Emitter* emitters, lane_int index, lane_float3 p, lane_float3 q,
                                lane_float cos_light) {
    lane_float radius = LANE_LOAD(emitters, index, .p0.w);
    lane_float3 to_centre = l3_sub(LANE_LOAD3(emitters, index, .p0), p);
    lane_float dist2_centre = l3_dot(to_centre, to_centre);
    lane_int flipped = radius < 0.0f;
    lane_float pdf_w = 0.0f;
    if (lane_any(flipped)) {
        lane_float3 d = l3_sub(q, p);
        lane_int inside = (dist2_centre < radius * radius) & (cos_light > 0.0f);
        pdf_w = select(pdf_w, l3_dot(d, d) / (cos_light * 4.0f * PI_F * radius * radius), flipped & inside);
    }
    if (lane_any(!flipped)) {
        lane_float sin2_max = radius * radius / dist2_centre;
        pdf_w = select(pdf_w, 1.0f / (2.0f * PI_F * sphere_cone_one_minus_cos(sin2_max)), !flipped & (sin2_max < 1.0f));
    }
    return pdf_w;
}

// A point q on emitting sphere `index` seen from p, with the solid-angle pdf of its direction (0,
// and q = p, when p sees no front face). q is moved off the surface towards p by its rounding
// bound, so that the shadow ray to it stops short of the sphere.
lane_float3 sample_sphere_emitter(__global const Emitter* emitters, lane_int index, lane_float3 p, lane_float2 u,
                                  lane_float* pdf_w) {
    lane_float3 centre = LANE_LOAD3(emitters, index, .p0);
    lane_float radius = LANE_LOAD(emitters, index, .p0.w);
    lane_float3 to_centre = l3_sub(centre, p);
    lane_float dist2_centre = l3_dot(to_centre, to_centre);
    lane_float sin2_max = radius * radius / dist2_centre;
    lane_int flipped = radius < 0.0f;
    lane_int seen = select(sin2_max < 1.0f, sin2_max > 1.0f, flipped);
    *pdf_w = 0.0f;
    if (!lane_any(seen)) return p;
    lane_float3 n = l3_splat(0.0f);   // unit direction from the centre to q
    if (lane_any(flipped)) n = sample_uniform_sphere(u);
    if (lane_any(!flipped)) {
        // A direction at angle theta from the axis (uniform in the cone: 1 - cos theta = w), then
        // the point of the sphere it meets first, at angle alpha from the axis at the centre.
        lane_float w = u.x * sphere_cone_one_minus_cos(sin2_max);
        lane_float sin2_theta = w * (2.0f - w);
        lane_float cos_alpha = sin2_theta * rsqrt(sin2_max) +
                               (1.0f - w) * sqrt(fmax(0.0f, 1.0f - sin2_theta / sin2_max));
        lane_float sin_alpha = sqrt(fmax(0.0f, 1.0f - cos_alpha * cos_alpha));
        lane_float s, c;
        sincos_2pi(u.y, &s, &c);
        lane_float3 cone = l3_neg(to_world(make_lane_float3(sin_alpha * c, sin_alpha * s, cos_alpha),
                                           l3_scale(to_centre, rsqrt(dist2_centre))));
        n = l3_select(n, cone, !flipped);
    }
    lane_float error;
    lane_float3 q = sphere_point(centre, radius, n, &error);
    lane_float3 front = l3_select(n, l3_neg(n), flipped);
    lane_float3 to_p = l3_sub(p, q);
    q = offset_ray_origin(q, l3_select(l3_neg(n), n, l3_dot(to_p, n) > 0.0f), error);
    lane_float pdf_q = sphere_emitter_pdf_w(emitters, index, p, q, l3_dot(front, to_p) * rsqrt(l3_dot(to_p, to_p)));
    *pdf_w = select((lane_float)(0.0f), pdf_q, seen);
    return l3_select(p, q, seen);
}

// Solid-angle pdf of reaching q, a point on area emitter `index` with cosine cos_light towards
// p, from p (the MIS weight of emission that a BSDF or phase sample hits).
lane_float area_emitter_pdf_w(__global const Emitter* emitters, lane_int index, lane_float3 p, lane_float3 q,
                              lane_float cos_light) {
    lane_int sphere = LANE_LOAD_INT(emitters, index, .kind.x) == EMITTER_SPHERE;
    lane_float pdf_w = 0.0f;
    if (lane_any(sphere)) pdf_w = sphere_emitter_pdf_w(emitters, index, p, q, cos_light);
    if (lane_any(!sphere))
        pdf_w = select(pdf_w, triangle_emitter_pdf_w(LANE_LOAD(emitters, index, .p0.w), l3_length(l3_sub(q, p)),
                                                     cos_light), !sphere);
    return pdf_w;
}

#endif
