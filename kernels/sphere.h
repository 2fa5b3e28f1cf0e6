// Analytic spheres: the ray intersection, and the surface point with its rounding-error bound.
// A sphere lives in a primitive slot of the triangle buffer (layout: types.h, Sphere); its
// radius is signed: negative means flipped, the front face (normals, one-sided emission,
// the side a medium is "exterior" to) inside.
#ifndef CLRENDER_SPHERE_H
#define CLRENDER_SPHERE_H

#include "types.h"
#include "hit.h"

// Relative rounding bound of c = |f|^2 - r^2 (f: the ray origin relative to the centre): a few
// operations of FLT_EPSILON each, doubled for margin.
#define SPHERE_ON_SURFACE_EPS (8.0f * FLT_EPSILON)

// Ray/sphere intersection as Haines et al. ("Precision Improvements for Ray/Sphere
// Intersection", Ray Tracing Gems, ch. 7): the discriminant from the distance of the centre to
// the line (no cancellation of b^2 - ac for small or distant spheres), and each root by the
// formula that does not cancel (q / a and c / q). dir need not be unit length.
// A ray whose origin lies on the sphere to within the rounding of c (a ray spawned from it,
// offset by its error bound or not) cannot tell which side it starts on; the root nearer zero
// is then the origin itself and is dropped, the other one (the chord across) kept. Otherwise
// the sign of c is exact, so roots of either sign are never confused.
bool intersect_sphere(__global const Sphere* s, int slot, float3 origin, float3 dir, Hit* hit) {
    float3 centre = s->centre_radius.xyz;
    float r2 = s->centre_radius.w * s->centre_radius.w;
    float3 f = origin - centre;
    float a = dot(dir, dir);
    float b = -dot(f, dir);
    float3 l = f + (b / a) * dir;   // from the centre to the line's closest point
    float disc = r2 - dot(l, l);
    if (!(disc >= 0.0f)) return false;
    float f2 = dot(f, f);
    float c = f2 - r2;
    float q = b + copysign(sqrt(a * disc), b);
    float root0 = c / q, root1 = q / a;
    float t;
    if (fabs(c) <= SPHERE_ON_SURFACE_EPS * (f2 + r2)) {
        t = fabs(root0) < fabs(root1) ? root1 : root0;
    } else {
        float t_near = fmin(root0, root1), t_far = fmax(root0, root1);
        t = t_near > 0.0f ? t_near : t_far;
    }
    if (!(t > 0.0f && t < hit->t)) return false;
    hit->t = t;
    hit->prim = slot;
    hit->block_lane = 0;   // (a valid one, read and discarded where packets mix spheres and triangles)
    hit->sphere = true;
    hit->from_centre = f + t * dir;
    return true;
}

// Relative error of the reprojected point (pbrt-v4, sec. 6.8.5: gamma(5) |p| for the point
// scaled onto the sphere) with a margin for OpenCL's sqrt and normalize (a few ulp, not
// correctly rounded), and of adding the centre back.
#define SPHERE_POINT_EPS (16.0f * FLT_EPSILON)
#define SPHERE_CENTRE_EPS (2.0f * FLT_EPSILON)

// The point of a sphere in the direction of unit n from its centre: on the surface (the ray's
// hit point is only near it), and a bound on its error along n.
lane_float3 sphere_point(lane_float3 centre, lane_float radius, lane_float3 n, lane_float* error) {
    lane_float3 from_centre = l3_scale(n, fabs(radius));
    lane_float3 p = l3_add(centre, from_centre);
    *error = l3_dot(l3_abs(n), l3_add(l3_scale(l3_abs(from_centre), SPHERE_POINT_EPS), l3_scale(l3_abs(p), SPHERE_CENTRE_EPS)));
    return p;
}

#endif
