// The scene as the kernel sees it: buffers bundled so that functions take one argument, and the
// surface point reconstructed from a hit.
#ifndef CLRENDER_SCENE_H
#define CLRENDER_SCENE_H
#include "types.h"
#include "math.h"
#include "portability.h"
#include "bvh.h"
#include "bvh_packets.h"

typedef struct {
    __constant RenderParams* params;
    __global const WideBvhNode* nodes;
    __global const TriangleBlock* blocks;   // the BVH leaves' triangles, their only geometry (types.h)
    __global const Sphere* spheres;         // the records of the sphere slots, the first ones (types.h)
    __global const TriangleShading* shading;
    __global const TriangleInfo* info;
    __global const Material* materials;
    __global const Medium* media;
    __global const Emitter* emitters;
    __global const float* emitter_cdf;   // emitter count + 1 entries
    __global const float4* env_texels;   // environment image, row-major, top row first
    __global const float* env_cdf;       // marginal (height + 1), conditional rows (width + 1), their
                                         // every 16th entries (lights.h, ENV_CDF_BLOCK)
    __global const float* specular_albedo;  // energy-compensation tables (materials/energy.h)
    __global const float* grid_data;     // voxels of all grid media (medium_voxel_offset: first voxel)
    __global const float* majorant_data; // (max, min) per majorant block (medium_majorant_offset)
    __global const float2* uvs;          // texture coordinates of each primitive slot's 3 corners
    __global const Texture* textures;    // textures/texture.h
    __global const uchar* texels;        // every bitmap's texels, as stored (Texture.info.y: first byte)
    __global const GuideLobe* guide;     // the caustic guide's lobes, GUIDE_LOBES per cell (guide.h)
} Scene;

// The scene's arguments of every kernel that traces paths through it (render_pass, light_paths,
// guide_photons), in the order the host passes them (render.py: RenderParams, Renderer.ARRAYS),
// and the Scene they make (SCENE_OF_RENDER_PASS_ARGUMENTS).
#define RENDER_SCENE_ARGUMENTS __constant RenderParams* params, __global const WideBvhNode* nodes, \
    __global const TriangleBlock* blocks, __global const Sphere* spheres, __global const TriangleShading* shading, \
    __global const TriangleInfo* info, __global const Material* materials, __global const Medium* media, \
    __global const Emitter* emitters, __global const float* emitter_cdf, __global const float4* env_texels, \
    __global const float* env_cdf, __global const float* specular_albedo, __global const float* grid_data, \
    __global const float* majorant_data, __global const float2* uvs, __global const Texture* textures, \
    __global const uchar* texels, __global const GuideLobe* guide
// The arguments of render_pass: the scene's, then the per-pixel buffers, and the launch's first
// row of the tile (an argument, not a global offset, which PoCL compiles the kernel again for),
// for both of its forms (integrator.cl, integrator_packets.cl).
#define RENDER_PASS_ARGUMENTS RENDER_SCENE_ARGUMENTS, __global float4* accumulator, __global int* discarded_samples, \
    __global float4* aux_geometry, __global int* aux_object, __global AovSums* aov_sums, \
    __global float* splat_records, int first_row
#define SCENE_OF_RENDER_PASS_ARGUMENTS {params, nodes, blocks, spheres, shading, info, materials, media, emitters, \
    emitter_cdf, env_texels, env_cdf, specular_albedo, grid_data, majorant_data, uvs, textures, texels, guide}

// Per lane (lanes.h).
typedef struct {
    lane_float3 p;     // position, from barycentrics (more accurate than origin + t * dir)
    lane_float3 ng;    // unit geometric normal, on the side the ray came from
    lane_float3 ns;    // unit shading normal, on the same side as ng
    lane_float p_error;   // bound on the rounding error of p along ng (world units)
    lane_int front_face;  // ray arrived on the front side (the triangle's winding, a sphere's
                          // outside): a comparison's result
    lane_int material;
    lane_int object;
    lane_int emitter;
    lane_int media;    // packed media behind / in front of the front face (TriangleInfo.w)
#if TEXTURES && LANES == 1   // (packets look their textures up lane by lane: path_packets.h)
    float2 uv;         // texture coordinates, as Mitsuba's (surface_uv)
    float3 dpdu, dpdv; // the surface's derivatives along u and v (kernel lengths per unit uv)
    float3 ns_unbent;  // ns before a bump or normal map bent it (materials/shading_maps.h)
#endif
} SurfacePoint;

bool intersect_scene(const Scene* scene, float3 origin, float3 dir, float t_max, Hit* hit) {
    hit->t = t_max;
    hit->prim = -1;
    return traverse_bvh(scene->nodes, scene->blocks, scene->spheres, origin, dir, false, hit);
}

// The primitive slot of some surface (any, not the nearest) between origin and t_max along dir;
// -1 for none.
int occluder(const Scene* scene, float3 origin, float3 dir, float t_max) {
    Hit hit;
    hit.t = t_max;
    hit.prim = -1;
    return traverse_bvh(scene->nodes, scene->blocks, scene->spheres, origin, dir, true, &hit) ? hit.prim : -1;
}

bool occluded(const Scene* scene, float3 origin, float3 dir, float t_max) {
    return occluder(scene, origin, dir, t_max) >= 0;
}

// The nearest hits of the lanes' rays that are `active` (one traversal per lane: the tree is
// walked by the scalar traverse_bvh); returns the lanes that hit something. A lane without a hit
// gets prim 0 (a valid slot to read, never used).
lane_int closest_hits(const Scene* scene, lane_float3 origin, lane_float3 dir, lane_float t_max,
                      lane_int active, LaneHit* hit) {
#if LANES == 1
    return active && intersect_scene(scene, origin, dir, t_max, hit);
#else
    float o[3][8], d[3][8], t[8], b1[8], b2[8], from_centre[3][8];
    int live[8], prim[8], block_lane[8], sphere[8];
    vstore8(origin.x, 0, o[0]); vstore8(origin.y, 0, o[1]); vstore8(origin.z, 0, o[2]);
    vstore8(dir.x, 0, d[0]); vstore8(dir.y, 0, d[1]); vstore8(dir.z, 0, d[2]);
    vstore8(t_max, 0, t);
    vstore8(active, 0, live);
    for (int i = 0; i < 8; ++i) {
        Hit h;
        h.t = t[i];
        h.prim = -1;
        h.block_lane = 0;
        h.b1 = h.b2 = 0.0f;
        h.sphere = false;
        h.from_centre = (float3)(0.0f);
        if (live[i]) intersect_scene(scene, (float3)(o[0][i], o[1][i], o[2][i]), (float3)(d[0][i], d[1][i], d[2][i]), t[i], &h);
        if (h.prim >= 0) {   // what surface_point and the texture lookups read of it, after all lanes
            PREFETCH(scene->shading + h.prim);   // (its block has just been read)
            PREFETCH(scene->info + h.prim);
#if TEXTURES
            PREFETCH(scene->uvs + 3 * h.prim);
#endif
        }
        t[i] = h.t;
        b1[i] = h.b1;
        b2[i] = h.b2;
        prim[i] = h.prim;
        block_lane[i] = h.block_lane;
        sphere[i] = h.sphere ? -1 : 0;
        from_centre[0][i] = h.from_centre.x;
        from_centre[1][i] = h.from_centre.y;
        from_centre[2][i] = h.from_centre.z;
    }
    lane_int found = vload8(0, prim) >= 0;
    hit->t = vload8(0, t);
    hit->b1 = vload8(0, b1);
    hit->b2 = vload8(0, b2);
    hit->prim = max(vload8(0, prim), (int8)(0));   // not max(int8, int): Oclgrind computes that wrong
    hit->block_lane = vload8(0, block_lane);
    hit->sphere = vload8(0, sphere);
    hit->from_centre = make_lane_float3(vload8(0, from_centre[0]), vload8(0, from_centre[1]), vload8(0, from_centre[2]));
    return found;
#endif
}

// closest_hits for the lanes' camera rays, which leave one point (or a small lens) for 8 adjacent
// pixels: one walk for the packet (bvh_packets.h), x1.03-1.08 on the path-traced real scenes'
// renders, x1.42 on the teapot's (docs/performance.md, nineteenth pass).
lane_int closest_camera_hits(const Scene* scene, lane_float3 origin, lane_float3 dir, lane_int active, LaneHit* hit) {
#if LANES == 1
    return closest_hits(scene, origin, dir, INFINITY, active, hit);
#else
    traverse_bvh_packet(scene->nodes, scene->blocks, scene->spheres, origin, dir, (float8)(INFINITY), active, false, hit);
    lane_int found = active & (hit->prim >= 0);
    hit->t = select((float8)(INFINITY), hit->t, found);
    hit->prim = max(hit->prim, (int8)(0));   // not max(int8, int): Oclgrind computes that wrong
    return found;
#endif
}

// The primitive slot of some surface (any, not the nearest: occluder) between the lanes' origins
// and t_max along their rays (shadow rays), for the `active` lanes; -1 where there is none, and
// in the other lanes.
#if LANES > 1
lane_int occluders(const Scene* scene, lane_float3 origin, lane_float3 dir, lane_float t_max, lane_int active) {
    float o[3][8], d[3][8], t[8];
    int live[8], blocker[8];
    vstore8(origin.x, 0, o[0]); vstore8(origin.y, 0, o[1]); vstore8(origin.z, 0, o[2]);
    vstore8(dir.x, 0, d[0]); vstore8(dir.y, 0, d[1]); vstore8(dir.z, 0, d[2]);
    vstore8(t_max, 0, t);
    vstore8(active, 0, live);
    for (int i = 0; i < 8; ++i)
        blocker[i] = live[i] ? occluder(scene, (float3)(o[0][i], o[1][i], o[2][i]), (float3)(d[0][i], d[1][i], d[2][i]), t[i]) : -1;
    return vload8(0, blocker);
}

// occluders for shadow rays from adjacent camera hits toward one light (coherent: one walk for
// the packet, bvh_packets.h). Which occluder a lane gets depends on its packet-mates, whether it
// gets one does not: for callers that need no more (no masks: features.packets_cover).
lane_int coherent_occluders(const Scene* scene, lane_float3 origin, lane_float3 dir, lane_float t_max, lane_int active) {
    LaneHit hit;
    traverse_bvh_packet(scene->nodes, scene->blocks, scene->spheres, origin, dir, t_max, active, true, &hit);
    return hit.prim;
}
#endif

#define SURFACE_ERROR_EPS (4.0f * FLT_EPSILON)

// Member 0, 1 or 2 (v0, e1, e2) of the triangles that hits name by their block and lane
// (Hit.block_lane): each component a row of eight floats in the TriangleBlock (types.h). The
// words are indexed in 64 bits: an int index overflows past 26.8M blocks (MAX_TRIANGLES is 2^28).
lane_float3 block_triangle_member(const Scene* scene, lane_int block_lane, int member) {
    __global const float* words = (__global const float*)scene->blocks;
    const long block_words = sizeof(TriangleBlock) / sizeof(float);
#if LANES == 1
    long word = (long)(block_lane >> 3) * block_words + (block_lane & 7) + 24 * member;
    return (float3)(words[word], words[word + 8], words[word + 16]);
#else
    long8 word = convert_long8(block_lane >> 3) * block_words + convert_long8((block_lane & 7) + 24 * member);
    return make_lane_float3(LANE_LOAD(words, word, ), LANE_LOAD(words, word + 8, ), LANE_LOAD(words, word + 16, ));
#endif
}

#if TEXTURES
// Mitsuba's parameterisations: a triangle interpolates its corners' uv (a mesh without texture
// coordinates has corners (0, 0), (1, 0), (0, 1): uv = (b1, b2)), with dp/du, dp/dv solved
// from its edges (any basis of its plane where its uv are degenerate); a sphere has
// u = phi / 2 pi, v = theta / pi in its object frame (Sphere's x_axis and z_axis).

// The uv of the point of sphere `s` in unit direction n from its centre, and dp/du, dp/dv.
float2 sphere_uv(__global const Sphere* s, float3 n, float3* dpdu, float3* dpdv) {
    float radius = fabs(s->centre_radius.w);
    float3 x_axis = s->x_axis.xyz, z_axis = s->z_axis.xyz;
    float3 y_axis = cross(z_axis, x_axis) * s->z_axis.w;
    float3 q = (float3)(dot(n, x_axis), dot(n, y_axis), dot(n, z_axis));
    float phi = atan2(q.y, q.x);
    if (phi < 0.0f) phi += 2.0f * PI_F;
    float rd = sqrt(q.x * q.x + q.y * q.y);
    float3 du = (float3)(-q.y, q.x, 0.0f) * (2.0f * PI_F * radius);
    float3 dv = rd > 0.0f ? (float3)(q.z * q.x / rd, q.z * q.y / rd, -rd) : (float3)(1.0f, 0.0f, 0.0f);
    dv *= PI_F * radius;
    *dpdu = du.x * x_axis + du.y * y_axis + du.z * z_axis;
    *dpdv = dv.x * x_axis + dv.y * y_axis + dv.z * z_axis;
    return (float2)(phi * (0.5f * INV_PI_F), acos(clamp(q.z, -1.0f, 1.0f)) * INV_PI_F);
}

// The uv of triangle slot `prim` at barycentrics (b1, b2) of its second and third corners.
float2 triangle_uv(const Scene* scene, int prim, float b1, float b2) {
    __global const float2* corners = scene->uvs + 3 * prim;
    return corners[0] * (1.0f - b1 - b2) + corners[1] * b1 + corners[2] * b2;
}

#if LANES == 1
void surface_uv(const Scene* scene, const Hit* hit, SurfacePoint* sp) {
    if (hit->sphere) {
        sp->uv = sphere_uv(scene->spheres + hit->prim, normalize(hit->from_centre), &sp->dpdu, &sp->dpdv);
        return;
    }
    float3 e1 = block_triangle_member(scene, hit->block_lane, 1), e2 = block_triangle_member(scene, hit->block_lane, 2);
    sp->uv = triangle_uv(scene, hit->prim, hit->b1, hit->b2);
    __global const float2* corners = scene->uvs + 3 * hit->prim;
    float2 duv0 = corners[1] - corners[0], duv1 = corners[2] - corners[0];
    float det = duv0.x * duv1.y - duv0.y * duv1.x;
    if (det != 0.0f) {
        float inv_det = 1.0f / det;
        sp->dpdu = (duv1.y * e1 - duv0.y * e2) * inv_det;
        sp->dpdv = (duv0.x * e2 - duv1.x * e1) * inv_det;
    } else {
        make_basis(sp->ns, &sp->dpdu, &sp->dpdv);
    }
}
#endif
#endif

// A unit shading normal from its octahedral encoding (clrender/layout.py, pack_normals): x and y
// snorm16 in the low and high 16 bits, the octahedron's lower half folded back.
lane_float3 unpack_normal(lane_int packed) {
    lane_float x = lane_int_to_float((packed << 16) >> 16) * (1.0f / 32767.0f);
    lane_float y = lane_int_to_float(packed >> 16) * (1.0f / 32767.0f);
    lane_float z = 1.0f - fabs(x) - fabs(y);
    lane_float t = fmax(-z, 0.0f);
    x = x - select(-t, t, x >= 0.0f);
    y = y - select(-t, t, y >= 0.0f);
    return l3_normalize(make_lane_float3(x, y, z));
}

INLINE SurfacePoint surface_point(const Scene* scene, const LaneHit* hit, lane_float3 dir) {
    lane_int prim = hit->prim;
    lane_int is_sphere = hit->sphere != 0;
    SurfacePoint sp;
    lane_float3 ng = l3_splat(0.0f), ns = l3_splat(0.0f);   // the front face's normals
    lane_float3 p = l3_splat(0.0f);
    lane_float p_error = 0.0f;
    if (lane_any(is_sphere)) {
        // Exact geometry: the point on the sphere in the direction of the hit, its normal.
        lane_int sphere = select((lane_int)(0), prim, is_sphere);   // (the other lanes' slots lie beyond the records)
        lane_float3 centre = LANE_LOAD3(scene->spheres, sphere, .centre_radius);
        lane_float radius = LANE_LOAD(scene->spheres, sphere, .centre_radius.w);
        lane_float3 n = l3_normalize(hit->from_centre);
        lane_float sphere_error;
        lane_float3 sphere_p = sphere_point(centre, radius, n, &sphere_error);
        lane_float3 sphere_n = l3_select(n, l3_neg(n), radius < 0.0f);
        p = l3_select(p, sphere_p, is_sphere);
        p_error = select(p_error, sphere_error, is_sphere);
        ng = l3_select(ng, sphere_n, is_sphere);
        ns = l3_select(ns, sphere_n, is_sphere);
    }
    if (lane_any(!is_sphere)) {
        lane_float b1 = hit->b1, b2 = hit->b2;
        lane_float b0 = 1.0f - b1 - b2;
        lane_float3 v0 = block_triangle_member(scene, hit->block_lane, 0);
        lane_float3 e1 = block_triangle_member(scene, hit->block_lane, 1);
        lane_float3 e2 = block_triangle_member(scene, hit->block_lane, 2);
        lane_float3 triangle_p = l3_add(l3_add(v0, l3_scale(e1, b1)), l3_scale(e2, b2));
        lane_float3 triangle_ng = l3_normalize(l3_cross(e1, e2));
        // p is rounded relative to |v0| + |e1| + |e2| per component, and the intersector's
        // distance to the plane of a ray starting on the triangle is rounded relative to the
        // same sizes (its origin - v0 spans the triangle). SURFACE_ERROR_EPS times that bounds
        // both: in tests/test_dielectric.py (rays spawned at scales 1e-3 to 1e3, up to 3e7 from
        // the origin, down to 1e-4 from grazing) 1 FLT_EPSILON already suffices; 4 leaves a margin.
        lane_float3 magnitude = l3_add(l3_add(l3_abs(v0), l3_abs(e1)), l3_abs(e2));
        lane_float triangle_error = SURFACE_ERROR_EPS * l3_dot(l3_abs(triangle_ng), magnitude);
        lane_float3 interpolated = l3_add(l3_add(l3_scale(unpack_normal(LANE_LOAD_INT(scene->shading, prim, .normals.x)), b0),
                                                 l3_scale(unpack_normal(LANE_LOAD_INT(scene->shading, prim, .normals.y)), b1)),
                                          l3_scale(unpack_normal(LANE_LOAD_INT(scene->shading, prim, .normals.z)), b2));
        lane_float ns_len = l3_length(interpolated);
        lane_int smooth = LANE_LOAD_INT(scene->shading, prim, .normals.w) != 0;
        lane_float3 triangle_ns = l3_select(triangle_ng, l3_div(interpolated, ns_len), smooth & (ns_len > 0.0f));
        lane_int is_triangle = !is_sphere;
        p = l3_select(p, triangle_p, is_triangle);
        p_error = select(p_error, triangle_error, is_triangle);
        ng = l3_select(ng, triangle_ng, is_triangle);
        ns = l3_select(ns, triangle_ns, is_triangle);
    }
    sp.p = p;
    sp.p_error = p_error;
    sp.front_face = l3_dot(ng, dir) < 0.0f;
    sp.ng = l3_select(l3_neg(ng), ng, sp.front_face);
    sp.ns = l3_select(ns, l3_neg(ns), l3_dot(ns, sp.ng) < 0.0f);
    sp.material = LANE_LOAD_INT(scene->info, prim, .info.x);
    sp.object = LANE_LOAD_INT(scene->info, prim, .info.y);
    sp.emitter = LANE_LOAD_INT(scene->info, prim, .info.z);
    sp.media = LANE_LOAD_INT(scene->info, prim, .info.w);
#if TEXTURES && LANES == 1
    surface_uv(scene, hit, &sp);
#endif
    return sp;
}

// A path or shadow ray that keeps crossing index-matched boundaries or masks (e.g. coincident
// surfaces) must still end.
#define MAX_NULL_CROSSINGS 1024

// Origin of a ray leaving sp in direction dir: offset to the side dir goes (through the surface
// for transmission).
lane_float3 spawn_ray_origin(const SurfacePoint* sp, lane_float3 dir) {
    return offset_ray_origin(sp->p, l3_select(l3_neg(sp->ng), sp->ng, l3_dot(dir, sp->ng) > 0.0f), sp->p_error);
}

lane_float emitter_selection_pmf(const Scene* scene, lane_int emitter) {
    return LANE_LOAD(scene->emitter_cdf, emitter + 1, ) - LANE_LOAD(scene->emitter_cdf, emitter, );
}

// Its share of the scene's light power (kernels/types.h, Emitter e2.w).
float emitter_power_share(const Scene* scene, int emitter) { return scene->emitters[emitter].e2.w; }

#endif
