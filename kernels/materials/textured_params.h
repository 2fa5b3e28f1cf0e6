// Texture-driven material parameters (TEXTURES=1), and the material of a surface point (for
// packets, its colour). Lane w of a texturable member of the Material record (its emission and
// every parameter slot; clrender/layout.py) is -1 for a constant, or 2 x texture index + 1 for
// a number (lane x), + 0 for a colour (lanes xyz). At each hit the
// private copy of the material gets its textures' values there, once, before any material code
// reads it: materials stay unaware of where a value came from (pbrt-v4's texture evaluator).
#ifndef CLRENDER_TEXTURED_PARAMS_H
#define CLRENDER_TEXTURED_PARAMS_H
#include "types.h"
#include "scene.h"
#include "materials/material.h"
#include "textures/texture.h"

#if TEXTURES
float4 textured_value(const Scene* scene, float4 member, float2 uv) {
    if (!(member.w >= 0.0f)) return member;
    int reference = (int)member.w;
    int index = reference >> 1;
    if (reference & 1) member.x = eval_texture_number(scene, index, uv);
    else member.xyz = eval_texture(scene, index, uv);
    return member;
}

void resolve_textured_params(const Scene* scene, Material* m, float2 uv) {
    m->emission = textured_value(scene, m->emission, uv);
    for (int k = 0; k < MATERIAL_SLOTS; ++k) m->slot[k] = textured_value(scene, m->slot[k], uv);
}

#endif

#if LANES == 1
// The material at surface point sp, its textures evaluated there: what path vertices read. Seen
// from behind, a material with a back material is that one (Mitsuba's twosided with two BSDFs;
// the frame is already the back's: ng and ns face the ray).
Material surface_material(const Scene* scene, const SurfacePoint* sp) {
    Material m = scene->materials[sp->material];
#if TEXTURES
    int back = material_back_material(&m);
    if (!sp->front_face && back >= 0) m = scene->materials[back];
    resolve_textured_params(scene, &m, sp->uv);
#endif
    return m;
}

#else
// The packets' surface_material: the parameter in `slot` (material.h: the colour or the opacity,
// the parameters the packets take from textures, features.py) of the lanes' materials at their
// hits, from its texture where it has one (a number in x). A lookup mostly waits for memory (the
// hit's uv, then texels): each step is taken for every lane before the next, so that the lanes'
// loads are in flight together (uv corners gathered at once; bilinear bitmaps' texel positions
// first, then their texels).
lane_float3 surface_slot_lanes(const Scene* scene, const LaneHit* hit, lane_int material, int slot, lane_int alive) {
    lane_float3 value = LANE_LOAD3(scene->materials, material, .slot[slot]);
#if TEXTURES
    lane_int textured = alive & (LANE_LOAD(scene->materials, material, .slot[slot].w) >= 0.0f);
    if (!lane_any(textured)) return value;
    // triangle_uv of the textured triangles (other lanes read slot 0's corners)
    lane_int corner = select((lane_int)(0), 3 * hit->prim, textured & (hit->sphere == 0));
    lane_float b0 = 1.0f - hit->b1 - hit->b2;
    lane_float u = LANE_LOAD(scene->uvs, corner, .x) * b0 + LANE_LOAD(scene->uvs, corner + 1, .x) * hit->b1 +
                   LANE_LOAD(scene->uvs, corner + 2, .x) * hit->b2;
    lane_float v = LANE_LOAD(scene->uvs, corner, .y) * b0 + LANE_LOAD(scene->uvs, corner + 1, .y) * hit->b1 +
                   LANE_LOAD(scene->uvs, corner + 2, .y) * hit->b2;
    float rgb[3][8], us[8], vs[8], from_centre[3][8];
    int lookup[8], prim[8], index[8], sphere[8];
    vstore8(value.x, 0, rgb[0]); vstore8(value.y, 0, rgb[1]); vstore8(value.z, 0, rgb[2]);
    vstore8(u, 0, us); vstore8(v, 0, vs);
    vstore8(hit->from_centre.x, 0, from_centre[0]);
    vstore8(hit->from_centre.y, 0, from_centre[1]);
    vstore8(hit->from_centre.z, 0, from_centre[2]);
    vstore8(textured, 0, lookup); vstore8(hit->prim, 0, prim); vstore8(material, 0, index);
    vstore8(hit->sphere, 0, sphere);
    float4 member[8];
    float2 uv[8];
    TexelCorners corners[8];
    bool bilinear[8];
    for (int i = 0; i < 8; ++i) {
        if (!lookup[i]) continue;
        member[i] = scene->materials[index[i]].slot[slot];
        uv[i] = (float2)(us[i], vs[i]);
        if (sphere[i]) {
            float3 n = normalize((float3)(from_centre[0][i], from_centre[1][i], from_centre[2][i]));
            float3 dpdu, dpdv;   // (unused)
            uv[i] = sphere_uv(scene->spheres + prim[i], n, &dpdu, &dpdv);
        }
        int reference = (int)member[i].w;
        __global const Texture* t = scene->textures + (reference >> 1);
        bilinear[i] = (reference & 1) == 0 && t->info.x == TEXTURE_BITMAP && t->format.z != FILTER_NEAREST;
        if (bilinear[i]) {
            corners[i] = bilinear_corners(t, texture_st(t, uv[i]));
            prefetch_bilinear_texels(scene, t, corners[i]);   // read in the next loop
        }
    }
    for (int i = 0; i < 8; ++i) {
        if (!lookup[i]) continue;
        __global const Texture* t = scene->textures + ((int)member[i].w >> 1);
        float4 found = bilinear[i] ? (float4)(blend_texels(bilinear_texels_at(scene, t, corners[i])), 0.0f)
                                   : textured_value(scene, member[i], uv[i]);
        rgb[0][i] = found.x;
        rgb[1][i] = found.y;
        rgb[2][i] = found.z;
    }
    value = make_lane_float3(vload8(0, rgb[0]), vload8(0, rgb[1]), vload8(0, rgb[2]));
#endif
    return value;
}

lane_float3 surface_color_lanes(const Scene* scene, const LaneHit* hit, lane_int material, lane_int alive) {
    return surface_slot_lanes(scene, hit, material, MATERIAL_COLOR_SLOT, alive);
}

#if TEXTURES
// mask.h's mask_opacity of the lanes' materials at their hits.
lane_float surface_opacity_lanes(const Scene* scene, const LaneHit* hit, lane_int material, lane_int alive) {
    return clamp(surface_slot_lanes(scene, hit, material, MATERIAL_OPACITY_SLOT, alive).x, 0.0f, 1.0f);
}
#endif
#endif

#endif
