// A ray's nearest intersection, as the primitive intersectors (bvh.h, sphere.h) record it.
#ifndef CLRENDER_HIT_H
#define CLRENDER_HIT_H
#include "lanes.h"

typedef struct {
    float t;
    float b1, b2;   // triangles: barycentrics of v1 and v2
    int prim;       // primitive slot (index into the reordered primitive arrays), -1 for a miss
    int block_lane; // triangles: block * 8 + lane of the triangle in its leaf's TriangleBlock
    bool sphere;    // the slot holds an analytic sphere (sphere.h), not a triangle
    float3 from_centre;   // spheres: the hit point relative to the centre, from the ray
} Hit;

// The hits of a work-item's lanes (lanes.h): Hit itself for one lane.
#if LANES == 1
typedef Hit LaneHit;
#else
typedef struct {
    lane_float t, b1, b2;
    lane_int prim;      // clamped to a valid slot in lanes without a hit
    lane_int block_lane;   // clamped to a valid one likewise (lanes of spheres included)
    lane_int sphere;    // a comparison's result
    lane_float3 from_centre;
} LaneHit;
#endif

#endif
