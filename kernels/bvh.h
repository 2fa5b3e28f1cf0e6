// Closest-hit and any-hit traversal of the eight-wide BVH (layout in types.h) over triangles and
// analytic spheres.
#ifndef CLRENDER_BVH_H
#define CLRENDER_BVH_H
#include "types.h"

#include "hit.h"
#include "sphere.h"

// Each wide level pushes at most 7 siblings and the binary tree is at most 63 deep (bvh.py), so
// 7 * 62 + 1 entries always suffice (on GPUs the array lives in local memory either way).
#define BVH_STACK_SIZE 435

// Moller-Trumbore, two-sided. Returns true and updates *hit if closer than hit->t.
bool intersect_triangle(__global const Triangle* tri, int index, float3 origin, float3 dir,
                        Hit* hit) {
    float3 e1 = tri->e1.xyz, e2 = tri->e2.xyz;
    float3 pv = cross(dir, e2);
    float det = dot(e1, pv);
    if (det == 0.0f) return false;  // ray parallel to the plane, or a degenerate triangle
    float inv_det = 1.0f / det;
    float3 tv = origin - tri->v0.xyz;
    float b1 = dot(tv, pv) * inv_det;
    if (b1 < 0.0f || b1 > 1.0f) return false;
    float3 qv = cross(tv, e1);
    float b2 = dot(dir, qv) * inv_det;
    if (b2 < 0.0f || b1 + b2 > 1.0f) return false;
    float t = dot(e2, qv) * inv_det;
    if (!(t > 0.0f && t < hit->t)) return false;
    hit->t = t;
    hit->b1 = b1;
    hit->b2 = b2;
    hit->prim = index;
    hit->sphere = false;
    return true;
}

// Entry distances of a ray into the eight boxes of a wide node (INFINITY where missed).
// Each plane distance is one fma, lo * inv_dir - origin * inv_dir (origin * inv_dir is the same
// for every node; measured 1.6x faster traversal on PoCL than (lo - origin) * inv_dir). That
// product is rounded relative to |origin * inv_dir|, which far from the world origin exceeds the
// distance to boxes just ahead: each plane distance is widened by that rounding error, and the
// exit by 2 gamma(3) for the rest (pbrt-v4, sec. 6.8.2), so rounding never rejects a box the
// ray crosses. Empty lanes (corners at +inf) get an entry of +inf or an exit before the entry.
// The smaller and larger of two values, per lane. No operand is NaN here, so fmin/fmax's NaN
// rules (three instructions each on x86) are not needed; unlike OpenCL's min/max these are
// defined for infinities (the empty lanes' boxes), and compile to one vminps/vmaxps.
float8 min8(float8 a, float8 b) { return select(b, a, a < b); }
float8 max8(float8 a, float8 b) { return select(b, a, a > b); }

float8 intersect_boxes(__global const WideBvhNode* n, float3 origin_scaled, float3 rounding,
                       float3 inv_dir, float t_max) {
    float8 x0 = fma(n->lo_x, inv_dir.x, -origin_scaled.x), x1 = fma(n->hi_x, inv_dir.x, -origin_scaled.x);
    float8 y0 = fma(n->lo_y, inv_dir.y, -origin_scaled.y), y1 = fma(n->hi_y, inv_dir.y, -origin_scaled.y);
    float8 z0 = fma(n->lo_z, inv_dir.z, -origin_scaled.z), z1 = fma(n->hi_z, inv_dir.z, -origin_scaled.z);
    float8 t_enter = max8(max8(min8(x0, x1) - rounding.x, min8(y0, y1) - rounding.y),
                          max8(min8(z0, z1) - rounding.z, (float8)(0.0f)));
    float8 t_exit = min8(min8(max8(x0, x1) + rounding.x, max8(y0, y1) + rounding.y),
                         max8(z0, z1) + rounding.z) * (1.0f + 2.0f * 3.0f * FLT_EPSILON);
    return select((float8)(INFINITY), t_enter, t_enter <= min8(t_exit, (float8)(t_max)));
}

// Intersect the primitives of a leaf: count > 0 triangles, count < 0 spheres (the type tag)
// from primitive slot first. Returns whether one is nearer than hit->t (then recorded there).
// Inlined into the traversal loop: as a call it spills the loop's vector registers (3.6% of the
// Cornell box's time on PoCL).
INLINE bool intersect_leaf(__global const Triangle* triangles, int first, int count, float3 origin,
                    float3 dir, bool any_hit, Hit* hit) {
    bool found = false;
    if (count > 0) {
        for (int i = first; i < first + count && !(found && any_hit); ++i)
            found |= intersect_triangle(triangles + i, i, origin, dir, hit);
    } else {
        for (int i = first; i < first - count && !(found && any_hit); ++i)
            found |= intersect_sphere((__global const Sphere*)(triangles + i), i, origin, dir, hit);
    }
    return found;
}

// any_hit: stop at the first intersection (shadow rays).
bool traverse_bvh(__global const WideBvhNode* nodes, __global const Triangle* triangles,
                  float3 origin, float3 dir, bool any_hit, Hit* hit) {
    // Zero direction components are replaced by a tiny value of the same sign: an infinite
    // inverse would give 0 * inf = NaN for a box face through the origin, and the NaN would
    // decide the slab test by accident.
    float3 safe_dir = (float3)(fabs(dir.x) > 1e-12f ? dir.x : copysign(1e-12f, dir.x),
                               fabs(dir.y) > 1e-12f ? dir.y : copysign(1e-12f, dir.y),
                               fabs(dir.z) > 1e-12f ? dir.z : copysign(1e-12f, dir.z));
    float3 inv_dir = 1.0f / safe_dir;
    float3 origin_scaled = origin * inv_dir;
    float3 rounding = fabs(origin_scaled) * (2.0f * FLT_EPSILON);
    int stack[BVH_STACK_SIZE];
    float stack_t[BVH_STACK_SIZE];  // entry distances: a popped node farther than the hit is skipped
    int stack_size = 0;
    int node = 0;
    bool found = false;
    for (;;) {
        __global const WideBvhNode* n = nodes + node;
        float lane_t[8];
        vstore8(intersect_boxes(n, origin_scaled, rounding, inv_dir, hit->t), 0, lane_t);
        __global const int* child = (__global const int*)&n->child;
        __global const int* count = (__global const int*)&n->count;
        // Leaf children are intersected at once; interior ones (count 0) go on the stack, sorted
        // so that the nearest is on top (insertion among this node's entries only). One loop
        // over the lanes, not eight copies: each call site of the leaf intersection would
        // otherwise spill and reload the traversal's registers.
        int first_pushed = stack_size;
#pragma unroll 1
        for (int lane = 0; lane < 8; ++lane) {
            float t = lane_t[lane];
            if (!(t < hit->t)) continue;
            if (count[lane] != 0) {
                found |= intersect_leaf(triangles, child[lane], count[lane], origin, dir, any_hit, hit);
                if (found && any_hit) return true;
            } else {
                int k = stack_size++;
                while (k > first_pushed && stack_t[k - 1] < t) {
                    stack[k] = stack[k - 1];
                    stack_t[k] = stack_t[k - 1];
                    --k;
                }
                stack[k] = child[lane];
                stack_t[k] = t;
            }
        }
        do {
            if (stack_size == 0) return found;
            --stack_size;
        } while (stack_t[stack_size] >= hit->t);
        node = stack[stack_size];
    }
}

#endif
