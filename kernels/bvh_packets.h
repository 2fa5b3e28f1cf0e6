// Closest hits of a packet's 8 coherent rays (LANES 8: camera rays of 8 adjacent pixels) walked
// through the eight-wide BVH together: one walk whose box and triangle tests take the 8 rays in
// the vector lanes, instead of 8 walks of one ray (bvh.h). A ray's hit must not depend on the
// other rays of its packet (tiles regroup the pixels into packets, and the images are the same
// bits however they are split): of equal distances the lowest primitive slot wins, and boxes
// and stack entries are culled only beyond a ray's hit, not at it, so each ray gets the least
// (distance, slot) among the primitives it meets, whatever the order of the walk.
#ifndef CLRENDER_BVH_PACKETS_H
#define CLRENDER_BVH_PACKETS_H
#include "lanes.h"
#include "types.h"
#include "hit.h"
#include "bvh.h"
#include "sphere.h"

#if LANES == 8
// The nearer of two hits: (t, slot) ordered by distance, then slot.
int8 nearer_hit(float8 t, int8 slot, float8 best_t, int8 best_slot) {
    return (t < best_t) | ((t == best_t) & (slot < best_slot));
}

// The spheres of leaf slots first .. first + count - 1 against the rays of `lanes`, one ray at a
// time (spheres are few; their test is intersect_sphere's).
void intersect_sphere_leaf_lanes(__global const Sphere* spheres, int first, int count, float8 ox, float8 oy,
                                 float8 oz, float8 dx, float8 dy, float8 dz, int8 lanes, LaneHit* hit) {
    float o[3][8], d[3][8], t[8], fc[3][8];
    int live[8], prim[8], sphere[8];
    vstore8(ox, 0, o[0]); vstore8(oy, 0, o[1]); vstore8(oz, 0, o[2]);
    vstore8(dx, 0, d[0]); vstore8(dy, 0, d[1]); vstore8(dz, 0, d[2]);
    vstore8(hit->t, 0, t);
    vstore8(hit->prim, 0, prim);
    vstore8(hit->sphere, 0, sphere);
    vstore8(hit->from_centre.x, 0, fc[0]); vstore8(hit->from_centre.y, 0, fc[1]); vstore8(hit->from_centre.z, 0, fc[2]);
    vstore8(lanes, 0, live);
    for (int i = 0; i < 8; ++i) {
        if (!live[i]) continue;
        for (int s = first; s < first + count; ++s) {
            Hit h;
            h.t = INFINITY;
            if (!intersect_sphere(spheres + s, s, (float3)(o[0][i], o[1][i], o[2][i]),
                                  (float3)(d[0][i], d[1][i], d[2][i]), &h))
                continue;
            if (!(h.t < t[i] || (h.t == t[i] && s < prim[i]))) continue;
            t[i] = h.t;
            prim[i] = s;
            sphere[i] = -1;
            fc[0][i] = h.from_centre.x; fc[1][i] = h.from_centre.y; fc[2][i] = h.from_centre.z;
        }
    }
    int8 changed = (vload8(0, prim) != hit->prim) | (vload8(0, t) != hit->t);
    hit->t = vload8(0, t);
    hit->prim = vload8(0, prim);
    hit->sphere = vload8(0, sphere);
    hit->block_lane = select(hit->block_lane, (int8)(0), changed);
    hit->from_centre = make_lane_float3(vload8(0, fc[0]), vload8(0, fc[1]), vload8(0, fc[2]));
}

// Moller-Trumbore as bvh.h's intersect_triangle_block, triangle by triangle of the leaf's block,
// each against the rays of `lanes`.
void intersect_triangle_block_lanes(__global const TriangleBlock* blocks, int block, int count, float8 ox,
                                    float8 oy, float8 oz, float8 dx, float8 dy, float8 dz, int8 lanes,
                                    LaneHit* hit) {
    __global const TriangleBlock* b = blocks + block;
    __global const float* v0_x = (__global const float*)&b->v0_x;
    __global const float* v0_y = (__global const float*)&b->v0_y;
    __global const float* v0_z = (__global const float*)&b->v0_z;
    __global const float* e1_x = (__global const float*)&b->e1_x;
    __global const float* e1_y = (__global const float*)&b->e1_y;
    __global const float* e1_z = (__global const float*)&b->e1_z;
    __global const float* e2_x = (__global const float*)&b->e2_x;
    __global const float* e2_y = (__global const float*)&b->e2_y;
    __global const float* e2_z = (__global const float*)&b->e2_z;
    __global const int* slot = (__global const int*)&b->slot;
    for (int k = 0; k < count; ++k) {
        float8 pv_x = dy * e2_z[k] - dz * e2_y[k];
        float8 pv_y = dz * e2_x[k] - dx * e2_z[k];
        float8 pv_z = dx * e2_y[k] - dy * e2_x[k];
        float8 det = e1_x[k] * pv_x + e1_y[k] * pv_y + e1_z[k] * pv_z;
        float8 inv_det = 1.0f / det;
        float8 tv_x = ox - v0_x[k], tv_y = oy - v0_y[k], tv_z = oz - v0_z[k];
        float8 b1 = (tv_x * pv_x + tv_y * pv_y + tv_z * pv_z) * inv_det;
        float8 qv_x = tv_y * e1_z[k] - tv_z * e1_y[k];
        float8 qv_y = tv_z * e1_x[k] - tv_x * e1_z[k];
        float8 qv_z = tv_x * e1_y[k] - tv_y * e1_x[k];
        float8 b2 = (dx * qv_x + dy * qv_y + dz * qv_z) * inv_det;
        float8 t = (e2_x[k] * qv_x + e2_y[k] * qv_y + e2_z[k] * qv_z) * inv_det;
        int8 s = (int8)(slot[k]);
        int8 hits = lanes & (det != 0.0f) & (b1 >= 0.0f) & (b2 >= 0.0f) & (b1 + b2 <= 1.0f) & (t > 0.0f) &
                    nearer_hit(t, s, hit->t, hit->prim);
        if (!any(hits)) continue;
        hit->t = select(hit->t, t, hits);
        hit->b1 = select(hit->b1, b1, hits);
        hit->b2 = select(hit->b2, b2, hits);
        hit->prim = select(hit->prim, s, hits);
        hit->block_lane = select(hit->block_lane, (int8)(block * 8 + k), hits);
        hit->sphere = select(hit->sphere, (int8)(0), hits);
    }
}

// The nearest hits before t_max of the rays of `active`, or with any_hit some hit of each (shadow
// rays: a ray stops searching at its first; which one it finds depends on the order of the walk,
// whether it finds one does not); hit->prim is -1 where a ray meets nothing (the caller clamps it).
void traverse_bvh_packet(__global const WideBvhNode* nodes, __global const TriangleBlock* blocks,
                         __global const Sphere* spheres, lane_float3 origin, lane_float3 dir, float8 t_max,
                         int8 active, bool any_hit, LaneHit* hit) {
    // ray_slabs per lane; the near plane of an axis differs between rays, so both planes are
    // tested and ordered, each with the margins that keep the test conservative (bvh.h).
    float8 safe_x = select(copysign((float8)(1e-12f), dir.x), dir.x, fabs(dir.x) > 1e-12f);
    float8 safe_y = select(copysign((float8)(1e-12f), dir.y), dir.y, fabs(dir.y) > 1e-12f);
    float8 safe_z = select(copysign((float8)(1e-12f), dir.z), dir.z, fabs(dir.z) > 1e-12f);
    float8 inv_x = 1.0f / safe_x, inv_y = 1.0f / safe_y, inv_z = 1.0f / safe_z;
    float8 scaled_x = origin.x * inv_x, scaled_y = origin.y * inv_y, scaled_z = origin.z * inv_z;
    float8 round_x = fabs(scaled_x) * (3.0f * FLT_EPSILON), round_y = fabs(scaled_y) * (3.0f * FLT_EPSILON),
           round_z = fabs(scaled_z) * (3.0f * FLT_EPSILON);
    float8 enter_x = -scaled_x - round_x, enter_y = -scaled_y - round_y, enter_z = -scaled_z - round_z;
    float8 exit_x = -scaled_x + round_x, exit_y = -scaled_y + round_y, exit_z = -scaled_z + round_z;
    hit->t = select((float8)(-INFINITY), t_max, active);   // an inactive ray enters no box
    hit->b1 = hit->b2 = 0.0f;
    hit->prim = -1;
    hit->block_lane = 0;
    hit->sphere = 0;
    hit->from_centre = make_lane_float3((float8)(0.0f), (float8)(0.0f), (float8)(0.0f));
    int stack[BVH_STACK_SIZE];
    float stack_t[BVH_STACK_SIZE];   // the least entry distance of the rays entering the node
    int stack_size = 0;
    int node = 0;
    for (;;) {
        __global const WideBvhNode* n = nodes + node;
        __global const float* lo_x = (__global const float*)&n->lo_x;
        __global const float* hi_x = (__global const float*)&n->hi_x;
        __global const float* lo_y = (__global const float*)&n->lo_y;
        __global const float* hi_y = (__global const float*)&n->hi_y;
        __global const float* lo_z = (__global const float*)&n->lo_z;
        __global const float* hi_z = (__global const float*)&n->hi_z;
        __global const int* child = (__global const int*)&n->child;
        __global const int* count = (__global const int*)&n->count;
        int first_pushed = stack_size;
        for (int lane = 0; lane < 8; ++lane) {
            if (child[lane] < 0) continue;   // an empty lane
            float8 ax = lo_x[lane] * inv_x, bx = hi_x[lane] * inv_x;
            float8 ay = lo_y[lane] * inv_y, by = hi_y[lane] * inv_y;
            float8 az = lo_z[lane] * inv_z, bz = hi_z[lane] * inv_z;
            float8 entry = max8(max8(min8(ax, bx) + enter_x, min8(ay, by) + enter_y),
                                max8(min8(az, bz) + enter_z, (float8)(0.0f)));
            float8 exit = min8(min8(max8(ax, bx) + exit_x, max8(ay, by) + exit_y), max8(az, bz) + exit_z) *
                          (1.0f + 2.0f * 3.0f * FLT_EPSILON);
            int8 entered = (entry <= exit) & (entry <= hit->t) & active;
            if (!any(entered)) continue;
            if (count[lane] != 0) {
                if (count[lane] > 0)
                    intersect_triangle_block_lanes(blocks, child[lane], count[lane], origin.x, origin.y, origin.z,
                                                   dir.x, dir.y, dir.z, entered, hit);
                else
                    intersect_sphere_leaf_lanes(spheres, child[lane], -count[lane], origin.x, origin.y, origin.z,
                                                dir.x, dir.y, dir.z, entered, hit);
                if (any_hit) {
                    active &= hit->prim < 0;
                    if (!any(active)) return;
                }
            } else {
                float8 e = select((float8)(INFINITY), entry, entered);
                float4 e4 = min8(e, e.s45670123).lo;
                float2 e2 = select(e4.hi, e4.lo, e4.lo < e4.hi);
                float nearest = e2.x < e2.y ? e2.x : e2.y;
                int k = stack_size++;   // nearest on top, as bvh.h
                while (k > first_pushed && stack_t[k - 1] < nearest) {
                    stack[k] = stack[k - 1];
                    stack_t[k] = stack_t[k - 1];
                    --k;
                }
                stack[k] = child[lane];
                stack_t[k] = nearest;
            }
        }
        float8 t = select((float8)(-INFINITY), hit->t, active);   // (any_hit: the rays still searching)
        float4 t4 = max8(t, t.s45670123).lo;
        float2 t2 = select(t4.hi, t4.lo, t4.lo > t4.hi);
        float farthest = t2.x > t2.y ? t2.x : t2.y;
        do {
            if (stack_size == 0) return;
            --stack_size;
        } while (stack_t[stack_size] > farthest);
        node = stack[stack_size];
    }
}
#endif

#endif
