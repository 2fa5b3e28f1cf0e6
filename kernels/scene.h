// The scene as the kernel sees it: buffers bundled so that functions take one argument, and the
// surface point reconstructed from a hit.
#ifndef CLRENDER_SCENE_H
#define CLRENDER_SCENE_H
#include "types.h"
#include "math.h"
#include "bvh.h"

typedef struct {
    __constant RenderParams* params;
    __global const WideBvhNode* nodes;
    __global const Triangle* triangles;
    __global const TriangleShading* shading;
    __global const TriangleInfo* info;
    __global const Material* materials;
    __global const Medium* media;
    __global const Emitter* emitters;
    __global const float* emitter_cdf;   // emitter count + 1 entries
    __global const float4* env_texels;   // environment image, row-major, top row first
    __global const float* env_cdf;       // marginal (height + 1) then conditional rows (width + 1)
    __global const float* specular_albedo;  // energy-compensation tables (materials/energy.h)
    __global const float* grid_data;     // voxels of all grid media (medium_voxel_offset: first voxel)
    __global const float* majorant_data; // (max, min) per majorant block (medium_majorant_offset)
} Scene;

typedef struct {
    float3 p;          // position, from barycentrics (more accurate than origin + t * dir)
    float3 ng;         // unit geometric normal, on the side the ray came from
    float3 ns;         // unit shading normal, on the same side as ng
    float p_error;     // bound on the rounding error of p along ng (world units)
    bool front_face;   // ray arrived on the front side (the triangle's winding, a sphere's outside)
    int material;
    int object;
    int emitter;
    int media;         // packed media behind / in front of the front face (TriangleInfo.w)
} SurfacePoint;

bool intersect_scene(const Scene* scene, float3 origin, float3 dir, float t_max, Hit* hit) {
    hit->t = t_max;
    hit->prim = -1;
    return traverse_bvh(scene->nodes, scene->triangles, origin, dir, false, hit);
}

bool occluded(const Scene* scene, float3 origin, float3 dir, float t_max) {
    Hit hit;
    hit.t = t_max;
    hit.prim = -1;
    return traverse_bvh(scene->nodes, scene->triangles, origin, dir, true, &hit);
}

#define SURFACE_ERROR_EPS (4.0f * FLT_EPSILON)

INLINE SurfacePoint surface_point(const Scene* scene, const Hit* hit, float3 dir) {
    __global const Triangle* tri = scene->triangles + hit->prim;
    int4 info = scene->info[hit->prim].info;
    SurfacePoint sp;
    float3 ng, ns;   // the front face's normals
    if (hit->sphere) {
        // Exact geometry: the point on the sphere in the direction of the hit, its normal.
        float4 sphere = ((__global const Sphere*)tri)->centre_radius;
        float3 n = normalize(hit->from_centre);
        sp.p = sphere_point(sphere.xyz, sphere.w, n, &sp.p_error);
        ng = ns = sphere.w < 0.0f ? -n : n;
    } else {
        __global const TriangleShading* sh = scene->shading + hit->prim;
        float b0 = 1.0f - hit->b1 - hit->b2;
        sp.p = tri->v0.xyz + hit->b1 * tri->e1.xyz + hit->b2 * tri->e2.xyz;
        ng = normalize(cross(tri->e1.xyz, tri->e2.xyz));
        // p is rounded relative to |v0| + |e1| + |e2| per component, and the intersector's
        // distance to the plane of a ray starting on the triangle is rounded relative to the
        // same sizes (its origin - v0 spans the triangle). SURFACE_ERROR_EPS times that bounds
        // both: in tests/test_dielectric.py (rays spawned at scales 1e-3 to 1e3, up to 3e7 from
        // the origin, down to 1e-4 from grazing) 1 FLT_EPSILON already suffices; 4 leaves a margin.
        float3 magnitude = fabs(tri->v0.xyz) + fabs(tri->e1.xyz) + fabs(tri->e2.xyz);
        sp.p_error = SURFACE_ERROR_EPS * dot(fabs(ng), magnitude);
        ns = b0 * sh->n0.xyz + hit->b1 * sh->n1.xyz + hit->b2 * sh->n2.xyz;
        float ns_len = length(ns);
        ns = ns_len > 0.0f ? ns / ns_len : ng;
    }
    sp.front_face = dot(ng, dir) < 0.0f;
    sp.ng = sp.front_face ? ng : -ng;
    sp.ns = dot(ns, sp.ng) < 0.0f ? -ns : ns;
    sp.material = info.x;
    sp.object = info.y;
    sp.emitter = info.z;
    sp.media = info.w;
    return sp;
}

// Origin of a ray leaving sp in direction dir: offset to the side dir goes (through the surface
// for transmission).
float3 spawn_ray_origin(const SurfacePoint* sp, float3 dir) {
    return offset_ray_origin(sp->p, dot(dir, sp->ng) > 0.0f ? sp->ng : -sp->ng, sp->p_error);
}

float emitter_selection_pmf(const Scene* scene, int emitter) {
    return scene->emitter_cdf[emitter + 1] - scene->emitter_cdf[emitter];
}

#endif
