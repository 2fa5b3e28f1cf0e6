// Textures (TEXTURES=1): the value of texture `index` at a surface's uv, as Mitsuba 3 defines
// its `bitmap` and `checkerboard` (clrender/textures.py has the definitions and the reference
// these are tested against). Materials never call these: their parameters are resolved once
// per hit (materials/textured_params.h).
#ifndef CLRENDER_TEXTURE_H
#define CLRENDER_TEXTURE_H
#include "types.h"
#include "scene.h"
#include "textures/srgb8.h"
#if TEXTURES

// Mitsuba's luminance of linear RGB (a colour texture read as a number).
#define LUMINANCE_WEIGHTS ((float3)(0.212671f, 0.715160f, 0.072169f))

float2 texture_st(__global const Texture* t, float2 uv) {
    float4 a = t->to_uv_u, b = t->to_uv_v;
    return (float2)(a.x * uv.x + a.y * uv.y + a.z, b.x * uv.x + b.y * uv.y + b.z);
}

// A texel index wrapped into [0, size).
int wrap_texel(int i, int size, int mode) {
    if (mode == WRAP_CLAMP) return clamp(i, 0, size - 1);
    int period = mode == WRAP_MIRROR ? 2 * size : size;
    int r = i % period;
    if (r < 0) r += period;
    return r >= size ? period - 1 - r : r;
}

// A texture coordinate moved by whole periods of the wrap mode into a range whose texel
// indices fit an int, [0, 1) or [0, 2) (mirror); clamping needs only [-1, 2].
float reduce_coordinate(float s, int mode) {
    if (mode == WRAP_CLAMP) return clamp(s, -1.0f, 2.0f);
    float period = mode == WRAP_MIRROR ? 2.0f : 1.0f;
    float r = s - period * floor(s / period);
    return r < period ? r : 0.0f;   // s / period rounded up to the next integer
}

// Linear RGB of texel (i, j) of a bitmap (grey repeated, alpha dropped).
float3 bitmap_texel(const Scene* scene, __global const Texture* t, int i, int j) {
    int channels = t->format.x, encoding = t->format.y;
    int first = (j * t->info.z + i) * channels;
    float3 v;
    if (encoding == TEXEL_FLOAT32) {
        __global const float* f = (__global const float*)(scene->texels + t->info.y) + first;
        v = channels == 1 ? (float3)(f[0]) : (float3)(f[0], f[1], f[2]);
    } else {
        __global const uchar* b = scene->texels + t->info.y + first;
        uchar3 c = channels == 1 ? (uchar3)(b[0]) : (uchar3)(b[0], b[1], b[2]);
        v = encoding == TEXEL_SRGB8
            ? (float3)(SRGB8_TO_LINEAR[c.x], SRGB8_TO_LINEAR[c.y], SRGB8_TO_LINEAR[c.z])
            : convert_float3(c) * (1.0f / 255.0f);
    }
    return v;
}

float3 eval_bitmap(const Scene* scene, __global const Texture* t, float2 st) {
    int width = t->info.z, height = t->info.w, wrap = t->format.w;
    float x = reduce_coordinate(st.x, wrap) * (float)width;
    float y = reduce_coordinate(st.y, wrap) * (float)height;
    if (t->format.z == FILTER_NEAREST)
        return bitmap_texel(scene, t, wrap_texel((int)floor(x), width, wrap), wrap_texel((int)floor(y), height, wrap));
    // Bilinear between texel centres, at (i + 0.5) / width.
    x -= 0.5f;
    y -= 0.5f;
    float fx = floor(x), fy = floor(y);
    int i = (int)fx, j = (int)fy;
    float wx = x - fx, wy = y - fy;
    int i0 = wrap_texel(i, width, wrap), i1 = wrap_texel(i + 1, width, wrap);
    int j0 = wrap_texel(j, height, wrap), j1 = wrap_texel(j + 1, height, wrap);
    float3 top = bitmap_texel(scene, t, i0, j0) * (1.0f - wx) + bitmap_texel(scene, t, i1, j0) * wx;
    float3 bottom = bitmap_texel(scene, t, i0, j1) * (1.0f - wx) + bitmap_texel(scene, t, i1, j1) * wx;
    return top * (1.0f - wy) + bottom * wy;
}

// Whether st lies in a check of color0 (both fractions on the same side of 1/2).
bool checkerboard_first(float2 st) {
    float2 f = st - floor(st);
    return (f.x > 0.5f) == (f.y > 0.5f);
}

float3 eval_checkerboard(__global const Texture* t, float2 st) {
    return checkerboard_first(st) ? t->color0.xyz : t->color1.xyz;
}

// Linear RGB of texture `index` at uv.
float3 eval_texture(const Scene* scene, int index, float2 uv) {
    __global const Texture* t = scene->textures + index;
    float2 st = texture_st(t, uv);
    return t->info.x == TEXTURE_CHECKERBOARD ? eval_checkerboard(t, st) : eval_bitmap(scene, t, st);
}

// The texture as a number, as Mitsuba 3.9's eval_1 gives it: a one-channel bitmap's value, an RGB
// bitmap's luminance; a checkerboard the mean of the colour of the *other* check (its eval_1
// swaps color0 and color1 against eval, and a constant colour's eval_1 is its channel mean).
float eval_texture_number(const Scene* scene, int index, float2 uv) {
    __global const Texture* t = scene->textures + index;
    if (t->info.x == TEXTURE_CHECKERBOARD)
        return mean3(checkerboard_first(texture_st(t, uv)) ? t->color1.xyz : t->color0.xyz);
    float3 v = eval_texture(scene, index, uv);
    return t->format.x == 1 ? v.x : dot(v, LUMINANCE_WEIGHTS);
}

#endif
#endif
