// Textures (TEXTURES=1): the value of texture `index` at a surface's uv, as Mitsuba 3 defines
// its `bitmap` and `checkerboard` (clrender/textures.py has the definitions and the reference
// these are tested against). Materials never call these: their parameters are resolved once
// per hit (materials/textured_params.h).
#ifndef CLRENDER_TEXTURE_H
#define CLRENDER_TEXTURE_H
#include "types.h"
#include "math.h"
#include "scene.h"
#include "portability.h"
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

// The first byte of texel (i, j) of a bitmap.
__global const uchar* bitmap_texel_bytes(const Scene* scene, __global const Texture* t, int i, int j) {
    int bytes = t->format.x * (t->format.y == TEXEL_FLOAT32 ? 4 : 1);
    return scene->texels + t->info.y + (j * t->info.z + i) * bytes;
}

// Linear RGB of texel (i, j) of a bitmap (grey repeated, alpha dropped).
float3 bitmap_texel(const Scene* scene, __global const Texture* t, int i, int j) {
    int channels = t->format.x, encoding = t->format.y;
    __global const uchar* b = bitmap_texel_bytes(scene, t, i, j);
    float3 v;
    if (encoding == TEXEL_FLOAT32) {
        __global const float* f = (__global const float*)b;
        v = channels == 1 ? (float3)(f[0]) : (float3)(f[0], f[1], f[2]);
    } else {
        uchar3 c = channels == 1 ? (uchar3)(b[0]) : (uchar3)(b[0], b[1], b[2]);
        v = encoding == TEXEL_SRGB8
            ? (float3)(SRGB8_TO_LINEAR[c.x], SRGB8_TO_LINEAR[c.y], SRGB8_TO_LINEAR[c.z])
            : convert_float3(c) * (1.0f / 255.0f);
    }
    return v;
}

// The four texels bilinear filtering blends at st (between texel centres, at (i + 0.5) / width):
// columns i0, i1 = i0 + 1 and rows j0, j1 = j0 + 1 (wrapped), w the weights of i1 and j1.
typedef struct { int i0, i1, j0, j1; float2 w; } TexelCorners;

TexelCorners bilinear_corners(__global const Texture* t, float2 st) {
    int width = t->info.z, height = t->info.w, wrap = t->format.w;
    float x = reduce_coordinate(st.x, wrap) * (float)width - 0.5f;
    float y = reduce_coordinate(st.y, wrap) * (float)height - 0.5f;
    float fx = floor(x), fy = floor(y);
    int i = (int)fx, j = (int)fy;
    TexelCorners c;
    c.i0 = wrap_texel(i, width, wrap);
    c.i1 = wrap_texel(i + 1, width, wrap);
    c.j0 = wrap_texel(j, height, wrap);
    c.j1 = wrap_texel(j + 1, height, wrap);
    c.w = (float2)(x - fx, y - fy);
    return c;
}

// Their values: v00 at (i0, j0), v10 at (i1, j0), v01 at (i0, j1), v11.
typedef struct { float3 v00, v10, v01, v11; float2 w; } TexelQuad;

TexelQuad bilinear_texels_at(const Scene* scene, __global const Texture* t, TexelCorners c) {
    TexelQuad q;
    q.v00 = bitmap_texel(scene, t, c.i0, c.j0);
    q.v10 = bitmap_texel(scene, t, c.i1, c.j0);
    q.v01 = bitmap_texel(scene, t, c.i0, c.j1);
    q.v11 = bitmap_texel(scene, t, c.i1, c.j1);
    q.w = c.w;
    return q;
}

// PREFETCH the lines of the texels at corners c (a row's two are next to each other).
void prefetch_bilinear_texels(const Scene* scene, __global const Texture* t, TexelCorners c) {
    PREFETCH(bitmap_texel_bytes(scene, t, c.i0, c.j0));
    PREFETCH(bitmap_texel_bytes(scene, t, c.i0, c.j1));
}

TexelQuad bilinear_texels(const Scene* scene, __global const Texture* t, float2 st) {
    return bilinear_texels_at(scene, t, bilinear_corners(t, st));
}

float3 blend_texels(TexelQuad q) {
    float3 top = q.v00 * (1.0f - q.w.x) + q.v10 * q.w.x;
    float3 bottom = q.v01 * (1.0f - q.w.x) + q.v11 * q.w.x;
    return top * (1.0f - q.w.y) + bottom * q.w.y;
}

float3 eval_bitmap(const Scene* scene, __global const Texture* t, float2 st) {
    int width = t->info.z, height = t->info.w, wrap = t->format.w;
    if (t->format.z == FILTER_NEAREST) {
        float x = reduce_coordinate(st.x, wrap) * (float)width;
        float y = reduce_coordinate(st.y, wrap) * (float)height;
        return bitmap_texel(scene, t, wrap_texel((int)floor(x), width, wrap), wrap_texel((int)floor(y), height, wrap));
    }
    return blend_texels(bilinear_texels(scene, t, st));
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

// A texture's RGB value as a number: a one-channel bitmap's value, else the luminance.
float texture_number(__global const Texture* t, float3 v) {
    bool grey = t->info.x == TEXTURE_BITMAP && t->format.x == 1;
    return grey ? v.x : dot(v, LUMINANCE_WEIGHTS);
}

// The texture as a number, as Mitsuba 3.9's eval_1 gives it: a bitmap's texture_number; a
// checkerboard the mean of the colour of the *other* check (its eval_1 swaps color0 and color1
// against eval, and a constant colour's eval_1 is its channel mean).
float eval_texture_number(const Scene* scene, int index, float2 uv) {
    __global const Texture* t = scene->textures + index;
    if (t->info.x == TEXTURE_CHECKERBOARD)
        return mean3(checkerboard_first(texture_st(t, uv)) ? t->color1.xyz : t->color0.xyz);
    return texture_number(t, eval_texture(scene, index, uv));
}

// The gradient of eval_texture_number with respect to the surface's uv, as Mitsuba's
// eval_1_grad: the derivative of the bilinear interpolant within its cell (one-sided on texel
// centres), 0 for nearest-filtered bitmaps and checkerboards (piecewise constant). Like
// Mitsuba's, it scales the texel differences by the transposed to_uv and then by the
// resolution per axis (the chain rule exactly where width = height or to_uv is diagonal).
float2 eval_texture_number_gradient(const Scene* scene, int index, float2 uv) {
    __global const Texture* t = scene->textures + index;
    if (t->info.x == TEXTURE_CHECKERBOARD || t->format.z == FILTER_NEAREST) return (float2)(0.0f);
    TexelQuad q = bilinear_texels(scene, t, texture_st(t, uv));
    float f00 = texture_number(t, q.v00), f10 = texture_number(t, q.v10);
    float f01 = texture_number(t, q.v01), f11 = texture_number(t, q.v11);
    float dx = (1.0f - q.w.y) * (f10 - f00) + q.w.y * (f11 - f01);
    float dy = (1.0f - q.w.x) * (f01 - f00) + q.w.x * (f11 - f10);
    float4 a = t->to_uv_u, b = t->to_uv_v;
    return (float2)((float)t->info.z * (a.x * dx + b.x * dy), (float)t->info.w * (a.y * dx + b.y * dy));
}

#endif
#endif
