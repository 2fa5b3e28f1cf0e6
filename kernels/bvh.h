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

// The smaller and larger of two values, per lane. No operand is NaN here, so fmin/fmax's NaN
// rules (three instructions each on x86) are not needed; unlike OpenCL's min/max these are
// defined for infinities (the empty lanes' boxes), and compile to one vminps/vmaxps.
float8 min8(float8 a, float8 b) { return select(b, a, a < b); }
float8 max8(float8 a, float8 b) { return select(b, a, a > b); }

// What the slab test needs of a ray, computed once per traversal. Each plane distance is one
// fma, plane * inv_dir + offset with offset = -origin * inv_dir (the same for every node;
// measured 1.6x faster traversal on PoCL than (plane - origin) * inv_dir). origin * inv_dir is
// rounded relative to its own size, which far from the world origin exceeds the distance to
// boxes just ahead: the entry planes' offsets are lowered and the exit planes' raised by
// 3 FLT_EPSILON |origin * inv_dir| (that rounding, the offset's own and a margin), and the exit
// widened by 2 gamma(3) for the rest (pbrt-v4, sec. 6.8.2), so rounding never rejects a box the
// ray crosses. Which of a box's two planes the ray meets first on an axis follows from the sign
// of its direction there: near_* (0 or 1) picks lo or hi, with no min/max per node.
typedef struct {
    float3 inv_dir;
    float3 enter_offset, exit_offset;
    int near_x, near_y, near_z;
} RaySlabs;

RaySlabs ray_slabs(float3 origin, float3 dir) {
    // Zero direction components are replaced by a tiny value of the same sign: an infinite
    // inverse would give 0 * inf = NaN for a box face through the origin, and the NaN would
    // decide the slab test by accident.
    float3 safe_dir = (float3)(fabs(dir.x) > 1e-12f ? dir.x : copysign(1e-12f, dir.x),
                               fabs(dir.y) > 1e-12f ? dir.y : copysign(1e-12f, dir.y),
                               fabs(dir.z) > 1e-12f ? dir.z : copysign(1e-12f, dir.z));
    RaySlabs r;
    r.inv_dir = 1.0f / safe_dir;
    float3 scaled = origin * r.inv_dir;
    float3 rounding = fabs(scaled) * (3.0f * FLT_EPSILON);
    r.enter_offset = -scaled - rounding;
    r.exit_offset = -scaled + rounding;
    r.near_x = safe_dir.x < 0.0f;
    r.near_y = safe_dir.y < 0.0f;
    r.near_z = safe_dir.z < 0.0f;
    return r;
}

// The lanes of a wide node whose box the ray enters before t_max, and (entry) the distances at
// which it enters each box. Empty lanes (corners at +inf) get an entry of +inf or an exit
// before the entry.
int8 intersect_boxes(__global const WideBvhNode* n, const RaySlabs* r, float t_max, float8* entry) {
    __global const float8* planes = &n->lo_x;   // lo_x, hi_x, lo_y, hi_y, lo_z, hi_z
    float8 t_enter = max8(max8(fma(planes[r->near_x], r->inv_dir.x, r->enter_offset.x),
                               fma(planes[2 + r->near_y], r->inv_dir.y, r->enter_offset.y)),
                          max8(fma(planes[4 + r->near_z], r->inv_dir.z, r->enter_offset.z), (float8)(0.0f)));
    float8 t_exit = min8(min8(fma(planes[1 - r->near_x], r->inv_dir.x, r->exit_offset.x),
                              fma(planes[3 - r->near_y], r->inv_dir.y, r->exit_offset.y)),
                         fma(planes[5 - r->near_z], r->inv_dir.z, r->exit_offset.z)) * (1.0f + 2.0f * 3.0f * FLT_EPSILON);
    *entry = t_enter;
    return t_enter <= t_exit & t_enter < t_max;
}

// Bit i set where lane i of a comparison's result (0 or -1 per lane) is true: the lanes are
// then visited by a loop over the set bits, with no branch for the lanes a ray does not enter.
// The lanes become bytes of 0 or 1 and one multiply gathers byte i's bit at bit 56 + i: on
// PoCL four instructions where an OR over the lanes took eight in a longer chain (3 % of the
// real scenes' renders, docs/performance.md).
uint lane_bits(int8 m) {
    ulong bytes = as_ulong(convert_uchar8(m & 1));
    return (uint)((bytes * 0x0102040810204080ul) >> 56);
}

// The index of the lowest set bit of x != 0: the zeros below it, counted as the ones of
// ~x & (x - 1) (OpenCL C 1.2 has no ctz; LLVM makes this one tzcnt).
int lowest_bit(uint x) { return popcount(~x & (x - 1u)); }

// Moller-Trumbore, two-sided, on the eight triangles of a leaf's block at once, without a branch
// per triangle (SIMD lanes on CPUs; pbrt-v4 and Embree test a leaf's triangles together too).
// Returns true and updates *hit if one is closer than hit->t: the nearest, and of equal
// distances the lowest lane (a repeated triangle never displaces its first copy). Inlined as
// intersect_leaf is: as a call it stalled on its entry and exit (5 % of veach-bidir's render).
INLINE bool intersect_triangle_block(__global const TriangleBlock* blocks, int block, float3 origin, float3 dir,
                                     Hit* hit) {
    __global const TriangleBlock* b = blocks + block;
    float8 pv_x = dir.y * b->e2_z - dir.z * b->e2_y;
    float8 pv_y = dir.z * b->e2_x - dir.x * b->e2_z;
    float8 pv_z = dir.x * b->e2_y - dir.y * b->e2_x;
    float8 det = b->e1_x * pv_x + b->e1_y * pv_y + b->e1_z * pv_z;
    float8 inv_det = 1.0f / det;   // +-inf for det 0: the tests below then fail (NaN or inf)
    float8 tv_x = origin.x - b->v0_x, tv_y = origin.y - b->v0_y, tv_z = origin.z - b->v0_z;
    float8 b1 = (tv_x * pv_x + tv_y * pv_y + tv_z * pv_z) * inv_det;
    float8 qv_x = tv_y * b->e1_z - tv_z * b->e1_y;
    float8 qv_y = tv_z * b->e1_x - tv_x * b->e1_z;
    float8 qv_z = tv_x * b->e1_y - tv_y * b->e1_x;
    float8 b2 = (dir.x * qv_x + dir.y * qv_y + dir.z * qv_z) * inv_det;
    float8 t = (b->e2_x * qv_x + b->e2_y * qv_y + b->e2_z * qv_z) * inv_det;
    int8 hits = det != 0.0f & b1 >= 0.0f & b2 >= 0.0f & b1 + b2 <= 1.0f & t > 0.0f & t < hit->t;
    float8 t_hit = select((float8)(INFINITY), t, hits);
    // No lane of t_hit is NaN (a lane without a hit is +inf), so selects do what fmin would
    // without its NaN handling (three instructions a step on x86).
    float4 n4 = min8(t_hit, t_hit.s45670123).lo;
    float2 nearer = select(n4.hi, n4.lo, n4.lo < n4.hi);
    float nearest = nearer.x < nearer.y ? nearer.x : nearer.y;
    if (!(nearest < hit->t)) return false;
    int lane = lowest_bit(lane_bits(t_hit == nearest));
    float lane_b1[8], lane_b2[8];
    int slot[8];
    vstore8(b1, 0, lane_b1);
    vstore8(b2, 0, lane_b2);
    vstore8(b->slot, 0, slot);
    hit->t = nearest;
    hit->b1 = lane_b1[lane];
    hit->b2 = lane_b2[lane];
    hit->prim = slot[lane];
    hit->block_lane = block * 8 + lane;
    hit->sphere = false;
    return true;
}

// Intersect the primitives of a leaf: count > 0 triangles (the block `child`), count < 0 spheres
// (the type tag) from primitive slot `child`. Returns whether one is nearer than hit->t (then
// recorded there). Inlined into the traversal loop: as a call it spills the loop's vector
// registers (3.6% of the Cornell box's time on PoCL).
INLINE bool intersect_leaf(__global const TriangleBlock* blocks, __global const Sphere* spheres, int child,
                           int count, float3 origin, float3 dir, bool any_hit, Hit* hit) {
    if (count > 0) return intersect_triangle_block(blocks, child, origin, dir, hit);
    bool found = false;
    for (int i = child; i < child - count && !(found && any_hit); ++i)
        found |= intersect_sphere(spheres + i, i, origin, dir, hit);
    return found;
}

// any_hit: stop at the first intersection (shadow rays).
bool traverse_bvh(__global const WideBvhNode* nodes, __global const TriangleBlock* blocks,
                  __global const Sphere* spheres,
                  float3 origin, float3 dir, bool any_hit, Hit* hit) {
    RaySlabs slabs = ray_slabs(origin, dir);
    int stack[BVH_STACK_SIZE];
    float stack_t[BVH_STACK_SIZE];  // entry distances: a popped node farther than the hit is skipped
    int stack_size = 0;
    int node = 0;
    bool found = false;
    // A shadow ray towards a light at infinity (the environment, a directional light) is
    // blocked, where it is, mostly by what encloses the scene (an interior's walls), which the
    // farthest boxes hold: it visits them first (the living room's renders 1.08x). Towards a
    // light at a finite distance the nearest first stays faster (veach-bidir's lamp 1.07x;
    // docs/performance.md, "Twenty-sixth pass").
    bool far_first = any_hit && !(hit->t < INFINITY);
    for (;;) {
        __global const WideBvhNode* n = nodes + node;
        float lane_t[8];
        float8 entry;
        uint entered = lane_bits(intersect_boxes(n, &slabs, hit->t, &entry));
        vstore8(entry, 0, lane_t);
        __global const int* child = (__global const int*)&n->child;
        __global const int* count = (__global const int*)&n->count;
        // Leaf children are intersected at once; interior ones (count 0) go on the stack, sorted
        // so that the nearest (far_first: the farthest) is on top (insertion among this node's
        // entries only). One loop over the lanes, not eight copies: each call site of the leaf
        // intersection would otherwise spill and reload the traversal's registers.
        int first_pushed = stack_size;
#pragma unroll 1
        while (entered != 0) {
            int lane = lowest_bit(entered);
            entered &= entered - 1;
            float t = lane_t[lane];
            if (!(t < hit->t)) continue;
            if (count[lane] != 0) {
                found |= intersect_leaf(blocks, spheres, child[lane], count[lane], origin, dir, any_hit, hit);
                if (found && any_hit) return true;
            } else {
                int k = stack_size++;
                while (k > first_pushed && (far_first ? stack_t[k - 1] > t : stack_t[k - 1] < t)) {
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
