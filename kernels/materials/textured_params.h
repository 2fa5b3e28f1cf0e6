// Texture-driven material parameters (TEXTURES=1), and the material of a surface point. Lane w of a texturable member of the Material
// record (its emission and every parameter slot; clrender/layout.py) is -1 for a constant, or
// 2 x texture index + 1 for a number (lane x), + 0 for a colour (lanes xyz). At each hit the
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

#endif
