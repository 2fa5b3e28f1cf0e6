// Emitters: area lights (emissive triangles and spheres), the environment (constant or lat-long
// image), point, spot and directional lights. One emitter is picked per shading point, half
// by power, half uniformly as Mitsuba (clrender/light_selection.py builds the CDF).
#ifndef CLRENDER_LIGHTS_H
#define CLRENDER_LIGHTS_H
#include "types.h"
#include "math.h"
#include "rng.h"
#include "sampling.h"
#include "scene.h"

#include "sphere.h"
#include "triangle_lights.h"
#include "area_lights.h"
#include "delta_lights.h"
#include "textures/texture.h"

typedef struct {
    float3 wi;        // unit direction towards the light
    float dist;       // distance to the sampled point (INFINITY for the environment/directional)
    float3 radiance;  // arriving radiance (irradiance-like for delta lights), before the pdf;
                      // the environment image's: 1 until light_sample_radiance looks it up
    float2 env_uv;    // the environment image's (u, v) drawn
    float pdf_w;      // solid-angle pdf including the selection probability; 1 * pmf for delta
    bool delta;
    int emitter;      // the emitter picked
} LightSample;

// ----- environment ---------------------------------------------------------------------------
#if ENVIRONMENT == ENVIRONMENT_IMAGE
// The image is looked up in its own frame (RenderParams.env_to_map turns world directions into
// it) at (u, v) in [0, 1)^2: v = theta / pi from +y, u the azimuth from -z towards +x shifted by
// environment_u_offset. ENV_LOOKUP_TEXEL: texel (u W, v H) is constant, u = 0.5 looks down -z.
// ENV_LOOKUP_MITSUBA (Mitsuba's envmap): bilinear between texel centres, column i's centre
// looking at azimuth (i + 0.5) / W of a turn from -z, rows at the poles (v = j / (H - 1)); u is
// that azimuth less half a column, so (u W, v (H - 1)) is the position among the texel centres.
// The sampling grid's cells tile the same (u, v) square.
float3 environment_to_map(const Scene* scene, float3 d) {
    __constant const float4* m = scene->params->env_to_map;
    return (float3)(dot(m[0].xyz, d), dot(m[1].xyz, d), dot(m[2].xyz, d));
}

float3 environment_from_map(const Scene* scene, float3 d) {
    __constant const float4* m = scene->params->env_to_map;
    return m[0].xyz * d.x + m[1].xyz * d.y + m[2].xyz * d.z;
}

float environment_u_offset(const Scene* scene) {
    return scene->params->env_lookup.x == ENV_LOOKUP_TEXEL ? 0.5f : -0.5f / (float)scene->params->environment.y;
}

// (u, v) of a direction in the image's frame, and sin(theta) (the pdf's Jacobian). theta by
// atan2 of (sin, cos) rather than acos: one routine (math.h), and no loss near the poles.
float2 direction_to_latlong(const Scene* scene, float3 d, float* sin_theta) {
    *sin_theta = sqrt(d.x * d.x + d.z * d.z);
    float u = atan2_turns(d.x, -d.z) + environment_u_offset(scene);
    float v = 2.0f * atan2_turns(*sin_theta, d.y);
    return (float2)(u - floor(u), v);
}

float3 environment_texel(const Scene* scene, float2 uv) {
    int w = scene->params->environment.y, h = scene->params->environment.z;
    int i = min((int)(uv.x * (float)w), w - 1), j = min((int)(uv.y * (float)h), h - 1);
    return scene->env_texels[j * w + i].xyz;
}

// Mitsuba's bilinear lookup: periodic across u = 0 (the last column's centre blends into the
// first's), rows clamped to the image.
float3 environment_bilinear(const Scene* scene, float2 uv) {
    int w = scene->params->environment.y, h = scene->params->environment.z;
    float x = uv.x * (float)w, y = uv.y * (float)(h - 1);
    int i = min((int)x, w - 1), j = min((int)y, h - 2);
    float fx = x - (float)i, fy = y - (float)j;
    int right = i + 1 < w ? i + 1 : 0;
    __global const float4* upper = scene->env_texels + j * w;
    __global const float4* lower = upper + w;
    float4 top = mix(upper[i], upper[right], fx), bottom = mix(lower[i], lower[right], fx);
    return mix(top, bottom, fy).xyz;
}

float3 environment_radiance_at(const Scene* scene, float2 uv) {
    return scene->params->env_lookup.x == ENV_LOOKUP_TEXEL ? environment_texel(scene, uv)
                                                           : environment_bilinear(scene, uv);
}

// The sampling grid's columns and rows head its tables (clrender/arrays.py, _environment_tables):
// cells of one or more texels (ENV_LOOKUP_TEXEL) or of the squares between texel centres.
int2 environment_sampling_grid(const Scene* scene) {
    return (int2)((int)scene->env_cdf[0], (int)scene->env_cdf[1]);
}

__global const float* environment_marginal(const Scene* scene) { return scene->env_cdf + 2; }

__global const float* environment_conditional(const Scene* scene, int2 grid, int row) {
    return environment_marginal(scene) + (grid.y + 1) + row * (grid.x + 1);
}

// After the CDFs, each one's every ENV_CDF_BLOCK-th entry (clrender/layout.py, ENV_CDF_BLOCK):
// the marginal's, then each row's. A search finds its block among these (a few cache lines, a
// quarter megabyte for all rows of the living room's map, which stay cached) and then its entry
// among the block's 16 in the full CDF (one or two lines). The same entry as one binary search
// over the CDF (the last cdf[i] <= u), which touched one line per halving of a 4 KiB row.

int env_cdf_blocks(int n) { return (n + ENV_CDF_BLOCK - 1) / ENV_CDF_BLOCK; }

__global const float* environment_block_starts(const Scene* scene, int2 grid, int row) {
    __global const float* marginal = environment_conditional(scene, grid, grid.y);
    return row < 0 ? marginal : marginal + env_cdf_blocks(grid.y) + row * env_cdf_blocks(grid.x);
}

// The last i < n with cdf[i] <= u, for a non-decreasing cdf with cdf[0] <= u: how many of
// cdf[1 .. n - 1] are <= u. Counted without branches: PoCL compiled a binary search's
// compare-and-select to a branch (LLVM's x86 cmov conversion), mispredicted half the time.
int count_cdf_at_most(__global const float* cdf, int n, float u) {
    int count = 0;
    for (int i = 1; i < n; i++) count += cdf[i] <= u;
    return count;
}

int sample_blocked_cdf_reuse(__global const float* cdf, __global const float* block_starts, int n, float u,
                             float* rescaled) {
    int first = count_cdf_at_most(block_starts, env_cdf_blocks(n), u) * ENV_CDF_BLOCK;
    int i = first + count_cdf_at_most(cdf + first, min(ENV_CDF_BLOCK, n - first), u);
    *rescaled = cdf_rescaled(u, cdf[i], cdf[i + 1]);
    return i;
}

// Solid-angle density of grid cell (i, j) at a direction sin_theta from the pole: the cell's
// probability times the grid's cell count is its (u, v) density, and d(u, v) / d(omega) is
// 1 / (2 pi^2 sin theta).
float environment_cell_pdf_w(const Scene* scene, int2 grid, int i, int j, float sin_theta) {
    __global const float* marginal = environment_marginal(scene);
    __global const float* conditional = environment_conditional(scene, grid, j);
    float pdf_uv = (float)(grid.x * grid.y) * (marginal[j + 1] - marginal[j]) * (conditional[i + 1] - conditional[i]);
    return sin_theta > 0.0f ? pdf_uv / (2.0f * PI_F * PI_F * sin_theta) : 0.0f;
}

float environment_pdf_uv_w(const Scene* scene, float2 uv, float sin_theta) {
    int2 grid = environment_sampling_grid(scene);
    int i = min((int)(uv.x * (float)grid.x), grid.x - 1), j = min((int)(uv.y * (float)grid.y), grid.y - 1);
    return environment_cell_pdf_w(scene, grid, i, j, sin_theta);
}

float3 environment_radiance(const Scene* scene, float3 dir) {
    float sin_theta;
    return environment_radiance_at(scene, direction_to_latlong(scene, environment_to_map(scene, dir), &sin_theta));
}

// The radiance along a direction and the solid-angle pdf of sampling it (an escaped ray under
// MIS): its (u, v) found once.
float3 environment_radiance_pdf_w(const Scene* scene, float3 dir, float* pdf_w) {
    float sin_theta;
    float2 uv = direction_to_latlong(scene, environment_to_map(scene, dir), &sin_theta);
    *pdf_w = environment_pdf_uv_w(scene, uv, sin_theta);
    return environment_radiance_at(scene, uv);
}

// Piecewise-constant inversion over the sampling grid: a row from the marginal CDF, then a
// column in that row. The drawn cell gives the pdf and *uv the radiance
// (environment_radiance_at), with no way back from the direction.
float3 sample_environment_direction(const Scene* scene, float2 u, float* pdf_w, float2* uv) {
    int2 grid = environment_sampling_grid(scene);
    float in_row, in_column;
    int j = sample_blocked_cdf_reuse(environment_marginal(scene), environment_block_starts(scene, grid, -1), grid.y,
                                     u.x, &in_row);
    int i = sample_blocked_cdf_reuse(environment_conditional(scene, grid, j), environment_block_starts(scene, grid, j),
                                     grid.x, u.y, &in_column);
    *uv = (float2)(((float)i + in_column) / (float)grid.x, clamp(((float)j + in_row) / (float)grid.y, 0.0f, 1.0f));
    float sin_theta, cos_theta, sin_phi, cos_phi;
    sincos_2pi(0.5f * uv->y, &sin_theta, &cos_theta);   // theta = v pi: half a turn
    sincos_2pi(uv->x - environment_u_offset(scene), &sin_phi, &cos_phi);
    sin_theta = fmax(sin_theta, 0.0f);
    *pdf_w = environment_cell_pdf_w(scene, grid, i, j, sin_theta);
    return environment_from_map(scene, (float3)(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi));
}
#elif ENVIRONMENT == ENVIRONMENT_CONSTANT
float3 environment_radiance(const Scene* scene, float3 dir) {
    return scene->emitters[scene->params->environment.x].radiance.xyz;
}

float3 environment_radiance_pdf_w(const Scene* scene, float3 dir, float* pdf_w) {
    *pdf_w = UNIFORM_SPHERE_PDF_W;
    return environment_radiance(scene, dir);
}

float3 environment_radiance_at(const Scene* scene, float2 uv) {
    return scene->emitters[scene->params->environment.x].radiance.xyz;
}

float3 sample_environment_direction(const Scene* scene, float2 u, float* pdf_w, float2* uv) {
    *pdf_w = UNIFORM_SPHERE_PDF_W;
    *uv = u;
    return sample_uniform_sphere(u);
}
#endif

// ----- area lights: their radiance (sampling and densities: area_lights.h) -----------------
// The radiance of area emitter e at its point q, sampled with u: Emitter.radiance, or where its
// lane w names a texture (as materials/textured_params.h), the texture's value at q's uv (the
// primitive slot in kind.y).
float3 area_emitter_radiance(const Scene* scene, __global const Emitter* e, float2 u, float3 q) {
#if TEXTURES
    if (e->radiance.w >= 0.0f) {
        int slot = e->kind.y;
        float2 uv;
        if (e->kind.x == EMITTER_SPHERE) {
            float3 dpdu, dpdv;
            uv = sphere_uv(scene->triangles + slot, normalize(q - e->p0.xyz), &dpdu, &dpdv);
        } else {
            float2 b = sample_triangle(u);   // as sample_triangle_emitter placed q
            uv = triangle_uv(scene, slot, b.x, b.y);
        }
        return eval_texture(scene, (int)e->radiance.w >> 1, uv);
    }
#endif
    return e->radiance.xyz;
}

// ----- point, spot and directional lights ----------------------------------------------------
// The light arriving at p from a point, spot or directional emitter (delta_lights.h), with pdf_w =
// pmf (the probability of having chosen it). Returns false for other kinds or a point or spot
// light at p.
bool delta_light_sample(__global const Emitter* e, float3 p, float pmf, LightSample* ls) {
    if (!delta_light_arriving(e, 0, p, &ls->wi, &ls->dist, &ls->radiance)) return false;
    ls->pdf_w = pmf;
    ls->delta = true;
    return true;
}

// ----- one sample --------------------------------------------------------------------------
INLINE LightSample sample_light(const Scene* scene, float3 p, Rng* rng) {
    LightSample ls;
    ls.emitter = -1;
    ls.pdf_w = 0.0f;
    ls.delta = false;
    ls.dist = INFINITY;
    ls.radiance = (float3)(0.0f);
    ls.wi = (float3)(0.0f, 0.0f, 1.0f);
    int count = scene->params->config.w;
    // One 2D draw picks the emitter (u.x) and, rescaled, places the sample on it: the points of
    // a stratified draw stay stratified over the whole light rather than over the share of them
    // that an independent pick sends to each emitter, and the draw saves a dimension.
    float2 u = rng_float2(rng);
    if (count == 0) return ls;
    float u_on_emitter;
    int index = sample_discrete_cdf_reuse(scene->emitter_cdf, count, u.x, &u_on_emitter);
    ls.emitter = index;
    u.x = u_on_emitter;
    float pmf = emitter_selection_pmf(scene, index);
    __global const Emitter* e = scene->emitters + index;
    int kind = e->kind.x;
    if (kind == EMITTER_TRIANGLE) {
        float dist, pdf_w;
        float3 wi = sample_triangle_emitter(scene, index, p, u, &dist, &pdf_w);
        if (!(dist > 0.0f)) return ls;
        ls.wi = wi;
        ls.dist = dist;
        ls.pdf_w = pmf * pdf_w;
        ls.radiance = ls.pdf_w > 0.0f ? area_emitter_radiance(scene, e, u, p + dist * wi) : (float3)(0.0f);
    } else if (kind == EMITTER_SPHERE) {
        float pdf_w;
        float3 q = sample_sphere_emitter(scene->emitters, index, p, u, &pdf_w);
        float3 d = q - p;
        float dist = length(d);
        if (!(pdf_w > 0.0f && dist > 0.0f)) return ls;
        ls.wi = d / dist;
        ls.dist = dist;
        ls.pdf_w = pmf * pdf_w;
        ls.radiance = area_emitter_radiance(scene, e, u, q);
    }
#if ENVIRONMENT != ENVIRONMENT_NONE
    else if (kind == EMITTER_ENVIRONMENT) {
        float pdf_w;
        ls.wi = sample_environment_direction(scene, u, &pdf_w, &ls.env_uv);
        ls.pdf_w = pmf * pdf_w;
        ls.radiance = (float3)(1.0f);
    }
#endif
    else if (kind == EMITTER_POINT || kind == EMITTER_SPOT || kind == EMITTER_DIRECTIONAL) {
        delta_light_sample(e, p, pmf, &ls);
    }
    return ls;
}

// The radiance a light sample brings. The environment image's is looked up only here, which
// callers reach once the shadow ray has passed: blocked samples skip its texels, whose cache
// misses were a fifth of the living room's render (docs/performance.md).
float3 light_sample_radiance(const Scene* scene, const LightSample* ls) {
#if ENVIRONMENT != ENVIRONMENT_NONE
    if (ls->emitter >= 0 && ls->emitter == scene->params->environment.x) return environment_radiance_at(scene, ls->env_uv);
#endif
    return ls->radiance;
}

#endif
