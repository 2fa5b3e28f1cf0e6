// Plain data shared with the host. Every struct is built from 16-byte vectors so that its
// layout equals the numpy dtypes in clrender/layout.py (checked by tests/test_layout.py).
// Enumerations (MATERIAL_*, EMITTER_*) are generated from layout.py and prepended by the host.
#ifndef CLRENDER_TYPES_H
#define CLRENDER_TYPES_H

// Eight-wide BVH node: the boxes of up to eight children, one child per lane. child: node index
// (count 0), or the TriangleBlock of a leaf of count triangles (count 1 to 8), or the first
// primitive slot of a leaf of -count spheres (count < 0); empty lanes: child -1, count 0, box at
// +inf.
typedef struct {
    float8 lo_x, hi_x, lo_y, hi_y, lo_z, hi_z;
    int8 child;
    int8 count;
} WideBvhNode;

// The record of a sphere's primitive slot (the sphere slots come first; a leaf with a negative
// count names them): centre_radius.xyz the centre, .w the radius, negative when the sphere is
// flipped (its front face inside); x_axis and z_axis.xyz its object frame's axes, z_axis.w -1
// where that frame is mirrored, else +1.
typedef struct { float4 centre_radius, x_axis, z_axis; } Sphere;
// The triangles of a BVH leaf, laid out for intersecting the eight at once: lane j of each member
// is triangle j's (v0 and the edges e1 = v1 - v0, e2 = v2 - v0, component by component), slot.s[j]
// its primitive slot. A leaf of fewer than eight repeats its last triangle in the lanes left. The
// only copy of the triangles' geometry: a hit keeps its block and lane (Hit.block_lane).
typedef struct { float8 v0_x, v0_y, v0_z, e1_x, e1_y, e1_z, e2_x, e2_y, e2_z; int8 slot; } TriangleBlock;
// normals.xyz: the corners' unit shading normals, octahedral snorm16 pairs (scene.h, unpack_normal);
// normals.w: 1 where they are given, 0 for a flat triangle (shaded by its geometric normal).
typedef struct { int4 normals; } TriangleShading;
// info: x material, y object id, z emitter index (-1: none),
// w media: bits 0-15 the medium behind the front face + 1, bits 16-31 the one in front + 1 (0: none)
typedef struct { int4 info; } TriangleInfo;

// Lanes named in clrender/layout.py (MATERIAL_FIELDS); read through materials/material.h. Lane w
// of emission and of every slot is a texture reference (materials/textured_params.h).
typedef struct { int4 kind; int4 maps; float4 emission; float4 slot[MATERIAL_SLOTS]; } Material;

// A texture (textures/texture.h); lanes as clrender/layout.py (TEXTURE) describes them.
typedef struct { int4 info; int4 format; float4 to_uv_u; float4 to_uv_v; float4 color0; float4 color1; } Texture;

// kind.x EMITTER_*. Triangle: p0.xyz, e1, e2, p0.w = area. Sphere: p0.xyz centre, p0.w signed
// radius (negative: flipped, emitting inwards). Point: p0 = position,
// radiance = intensity. Spot: as a point, and e1.xyz the unit axis it shines along, e1.w the
// cosine of its cutoff angle, e2.x the cosine of its beam width, e2.y the cutoff angle (radians),
// e2.z 1 / (cutoff - beam width) (0: no transition; lights.h, spot_falloff).
// Directional: p0 = unit direction towards the light, radiance = irradiance.
// Environment: radiance = constant radiance (or scale; an image is looked up as RenderParams says).
// Every kind: e2.w = its share of the scene's light power (toon shading's p_j; next-event
// estimation picks by emitter_cdf, clrender/light_selection.py).
typedef struct { int4 kind; float4 radiance; float4 p0; float4 e1; float4 e2; } Emitter;

// Lanes named in clrender/layout.py (MEDIUM_FIELDS); read through media/medium_record.h.
typedef struct {
    float4 sigma_a; float4 sigma_s; float4 params;
    int4 grid; int4 resolution; int4 majorant_resolution; float4 to_voxel[3];
    int4 albedo_grid; int4 albedo_resolution;
} Medium;

// right/up are pre-scaled by tan(fov/2) (and the aspect ratio), so a pixel's direction is
// forward + sx * right + sy * up with sx, sy in [-1, 1]. lens: x the aperture radius (0: a
// pinhole), y the distance of the plane in focus along forward (camera.h).
typedef struct { float4 origin; float4 forward; float4 right; float4 up; float4 lens; } Camera;

// The pixel reconstruction filter (filter.h; layout.py FILTER names the fields): kind.x PIXEL_FILTER_*.
typedef struct {
    int4 kind; float4 support; float4 shape; float4 cells[FILTER_CELLS];
    float4 edge_cdf[FILTER_EDGES / 4]; float4 edge_mass[FILTER_EDGES / 4];
} Filter;

typedef struct {
    Camera camera;
    int4 frame;        // x width, y height, z first sample index of this pass, w samples in pass
    int4 config;       // x max depth, y roulette depth, z seed, w emitter count
    int4 environment;  // x emitter index (-1: none), y image width, z image height,
                       // w what camera rays do not see (HIDE_* bits: path.h)
    int4 env_lookup;   // x how the environment image is looked up (ENV_LOOKUP_*: lights.h)
    float4 env_to_map[3];  // rows (xyz) of the rotation from world directions into the image's frame
    int4 media;        // x medium at the camera (-1: none), y spectral MIS on (1) / off (0)
    float4 volume;     // grid media: x ray-marching step (voxels), y multiple scattering when marching (1/0)
    float4 scene_sphere;  // xyz centre, w radius: bounds of the geometry
    int4 lights;       // x index of the first emitter that is not an area light (lights follow them)
    int4 tile;         // the pixels of this pass: x, y first column and row, z width, w height
    int4 splat;        // splatting (splat.h): the target tile as `tile` (z = 0: no splatting)
    int4 splat_reach;  // x the pixels beyond its own a sample's filter reaches (splat.h)
    int4 sampling;     // x the sampler of camera paths (SAMPLER_*, rng.h); y, z the direct
                       // integrator's light and BSDF samples per camera hit (0, 0: path tracing)
    Filter filter;     // the pixel reconstruction filter (filter.h)
    int4 light_paths;  // x light paths take the caustics (light_paths.h) (1) or not (0), y camera
                       // samples per light path
    float4 guide_grid;   // the caustic guide (guide.h): xyz the grid's lowest corner, w 1 / cell edge
    int4 guide_cells;    // xyz cells per axis, w diffuse sampling uses the guide (1) or not (0)
    float4 guide_cone;   // x the guide's share of diffuse samples, y cos of the cones' half angle,
                         // z 1 / a cone's solid angle
} RenderParams;

// A lobe of a caustic guide cell (guide.h; layout.py GUIDE_LOBE): direction.xyz the direction light
// arrives from, direction.w the cumulative weight of the cell's lobes up to this one.
typedef struct { float4 direction; } GuideLobe;

// Per-pixel sums of the sample-level AOVs (AOVS=1, kernels/aovs.h), beside the colour sums whose
// w counts the samples: albedo.xyz, normal.xyz and emission.xyz summed over the samples;
// colour_m2.xyz the sum of squared deviations of the colour samples from their mean (Welford).
// The w fields are unused.
typedef struct { float4 albedo; float4 normal; float4 emission; float4 colour_m2; } AovSums;

#endif
