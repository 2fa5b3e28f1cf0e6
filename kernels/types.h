// Plain data shared with the host. Every struct is built from 16-byte vectors so that its
// layout equals the numpy dtypes in clrender/layout.py (checked by tests/test_layout.py).
// Enumerations (MATERIAL_*, EMITTER_*) are generated from layout.py and prepended by the host.
#ifndef CLRENDER_TYPES_H
#define CLRENDER_TYPES_H

// Both children's boxes live in the parent. lo.w: child node index or first primitive (int bits);
// hi.w: primitive count (int bits), 0 for an interior child.
typedef struct { float4 left_lo, left_hi, right_lo, right_hi; } BvhNode;

typedef struct { float4 v0, e1, e2; } Triangle;
typedef struct { float4 n0, n1, n2; } TriangleShading;
// info: x material, y object id, z emitter index (-1: none), w medium pair (reserved)
typedef struct { int4 info; } TriangleInfo;

// kind: x MATERIAL_*; color: albedo (diffuse) or tint (dielectric: transmission, conductor:
// reflectance); params: x ior inside, y ior outside, z roughness (dielectric and conductor),
// w offset of the material's energy-compensation tables in Scene.specular_albedo (-1: none)
typedef struct { int4 kind; float4 color; float4 emission; float4 params; } Material;

// kind.x EMITTER_*. Triangle: p0.xyz, e1, e2, p0.w = area. Point: p0 = position,
// radiance = intensity. Directional: p0 = unit direction towards the light, radiance = irradiance.
typedef struct { int4 kind; float4 radiance; float4 p0; float4 e1; float4 e2; } Emitter;

// right/up are pre-scaled by tan(fov/2) (and the aspect ratio), so a pixel's direction is
// forward + sx * right + sy * up with sx, sy in [-1, 1].
typedef struct { float4 origin; float4 forward; float4 right; float4 up; } Camera;

typedef struct {
    Camera camera;
    int4 frame;        // x width, y height, z first sample index of this pass, w samples in pass
    int4 config;       // x max depth, y roulette depth, z seed, w emitter count
    int4 environment;  // x emitter index (-1: none), y image width, z image height
    float4 scene_sphere;  // xyz centre, w radius: bounds of the geometry
} RenderParams;

#endif
