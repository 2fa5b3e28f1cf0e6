// The environment emitter (ENVIRONMENT: a constant or a lat-long image): its radiance along a
// direction, sampling a direction from it (luminance-weighted for an image), and the radiance an
// escaping ray brings under MIS. Written over lane types (lanes.h): the megakernel's paths and
// the packets' lanes run the same code.
#ifndef CLRENDER_ENVIRONMENT_H
#define CLRENDER_ENVIRONMENT_H
#include "lanes.h"
#include "types.h"
#include "math.h"
#include "sampling.h"
#include "scene.h"
#include "portability.h"

#if ENVIRONMENT == ENVIRONMENT_IMAGE
// The image is looked up in its own frame (RenderParams.env_to_map turns world directions into
// it) at (u, v) in [0, 1)^2: v = theta / pi from +y, u the azimuth from -z towards +x shifted by
// environment_u_offset. ENV_LOOKUP_TEXEL: texel (u W, v H) is constant, u = 0.5 looks down -z.
// ENV_LOOKUP_MITSUBA (Mitsuba's envmap): bilinear between texel centres, column i's centre
// looking at azimuth (i + 0.5) / W of a turn from -z, rows at the poles (v = j / (H - 1)); u is
// that azimuth less half a column, so (u W, v (H - 1)) is the position among the texel centres.
// The sampling grid's cells tile the same (u, v) square.
lane_float3 environment_to_map(const Scene* scene, lane_float3 d) {
    __constant const float4* m = scene->params->env_to_map;
    return make_lane_float3(l3_dot(l3_uniform(m[0].xyz), d), l3_dot(l3_uniform(m[1].xyz), d),
                            l3_dot(l3_uniform(m[2].xyz), d));
}

lane_float3 environment_from_map(const Scene* scene, lane_float3 d) {
    __constant const float4* m = scene->params->env_to_map;
    return l3_add(l3_add(l3_scale(l3_uniform(m[0].xyz), d.x), l3_scale(l3_uniform(m[1].xyz), d.y)),
                  l3_scale(l3_uniform(m[2].xyz), d.z));
}

float environment_u_offset(const Scene* scene) {
    return scene->params->env_lookup.x == ENV_LOOKUP_TEXEL ? 0.5f : -0.5f / (float)scene->params->environment.y;
}

// (u, v) of a direction in the image's frame, and sin(theta) (the pdf's Jacobian). theta by
// atan2 of (sin, cos) rather than acos: one routine (math.h), and no loss near the poles.
lane_float2 direction_to_latlong(const Scene* scene, lane_float3 d, lane_float* sin_theta) {
    *sin_theta = sqrt(d.x * d.x + d.z * d.z);
    lane_float u = atan2_turns(d.x, -d.z) + environment_u_offset(scene);
    lane_float v = 2.0f * atan2_turns(*sin_theta, d.y);
    return make_lane_float2(u - floor(u), v);
}

lane_float3 environment_texel(const Scene* scene, lane_float2 uv) {
    int w = scene->params->environment.y, h = scene->params->environment.z;
    lane_int i = min(lane_float_to_int(uv.x * (float)w), (lane_int)(w - 1));
    lane_int j = min(lane_float_to_int(uv.y * (float)h), (lane_int)(h - 1));
    return LANE_LOAD3(scene->env_texels, j * w + i, );
}

// Mitsuba's bilinear lookup: periodic across u = 0 (the last column's centre blends into the
// first's), rows clamped to the image.
lane_float3 environment_bilinear(const Scene* scene, lane_float2 uv) {
    int w = scene->params->environment.y, h = scene->params->environment.z;
    lane_float x = uv.x * (float)w, y = uv.y * (float)(h - 1);
    lane_int i = min(lane_float_to_int(x), (lane_int)(w - 1)), j = min(lane_float_to_int(y), (lane_int)(h - 2));
    lane_float fx = x - lane_int_to_float(i), fy = y - lane_int_to_float(j);
    lane_int right = select((lane_int)(0), i + 1, i + 1 < w);
    lane_int upper = j * w, lower = upper + w;
    __global const float4* texels = scene->env_texels;
    lane_float3 top = l3_mix(LANE_LOAD3(texels, upper + i, ), LANE_LOAD3(texels, upper + right, ), fx);
    lane_float3 bottom = l3_mix(LANE_LOAD3(texels, lower + i, ), LANE_LOAD3(texels, lower + right, ), fx);
    return l3_mix(top, bottom, fy);
}

lane_float3 environment_radiance_at(const Scene* scene, lane_float2 uv) {
    return scene->params->env_lookup.x == ENV_LOOKUP_TEXEL ? environment_texel(scene, uv)
                                                           : environment_bilinear(scene, uv);
}

#if LANES > 1
// The texel rows environment_radiance_at(uv) reads, asked for (PREFETCH) in each of the `lanes`:
// the packets look a light sample's radiance up after its shadow ray, by when they have arrived.
void prefetch_environment_texels(const Scene* scene, lane_float2 uv, lane_int lanes) {
    int w = scene->params->environment.y, h = scene->params->environment.z;
    lane_int i = min(lane_float_to_int(uv.x * (float)w), (lane_int)(w - 1));
    lane_int j = min(lane_float_to_int(uv.y * (float)h), (lane_int)(h - 1));
    int first[8], live[8];
    vstore8(j * w + i, 0, first);
    vstore8(lanes, 0, live);
    for (int k = 0; k < 8; ++k) {
        if (!live[k]) continue;
        PREFETCH(scene->env_texels + first[k]);
        PREFETCH(scene->env_texels + min(first[k] + w, w * h - 1));
    }
}

// Each lane's `count` entries of table from at, asked for before a search reads them level by
// level: the lanes' cache misses (a row of the living room's map is a random 4 KiB of its 4 MiB
// of CDFs) then overlap instead of following one another.
void prefetch_cdf_entries(__global const float* table, lane_int at, int count) {
    int first[8];
    vstore8(at, 0, first);
    for (int k = 0; k < 8; ++k)
        for (int entry = 0; entry < count; entry += 16) PREFETCH(table + first[k] + entry);
}
#endif

// The sampling grid's columns and rows head its tables, scene->env_cdf (clrender/arrays.py,
// _environment_tables): cells of one or more texels (ENV_LOOKUP_TEXEL) or of the squares between
// texel centres. Then the marginal CDF (rows + 1 entries), each row's conditional CDF (columns
// + 1), and after the CDFs each one's every ENV_CDF_BLOCK-th entry: the marginal's, then each
// row's. A search finds its block among these (a few cache lines, a quarter megabyte for all
// rows of the living room's map, which stay cached) and then its entry among the block's 16 in
// the full CDF (one or two lines). The same entry as one binary search over the CDF (the last
// cdf[i] <= u), which touched one line per halving of a 4 KiB row. Offsets into env_cdf below.
int2 environment_sampling_grid(const Scene* scene) {
    return (int2)((int)scene->env_cdf[0], (int)scene->env_cdf[1]);
}

#define ENVIRONMENT_MARGINAL 2

lane_int environment_conditional(int2 grid, lane_int row) { return ENVIRONMENT_MARGINAL + (grid.y + 1) + row * (grid.x + 1); }

int env_cdf_blocks(int n) { return (n + ENV_CDF_BLOCK - 1) / ENV_CDF_BLOCK; }

// The block starts of `row`'s conditional CDF (the marginal's for row -1), after the CDFs.
lane_int environment_block_starts(int2 grid, lane_int row) {
    int marginal = ENVIRONMENT_MARGINAL + (grid.y + 1) + grid.y * (grid.x + 1);
    return select(marginal + env_cdf_blocks(grid.y) + row * env_cdf_blocks(grid.x), (lane_int)(marginal), row < 0);
}

// How many of table[at + 1 .. at + n - 1] are <= u (table[at] <= u; the entries non-decreasing).
// At one lane, counted without branches: contiguous loads the compiler vectorises (a binary
// search's compare-and-select compiled to a branch, mispredicted half the time). In packets each
// entry is a load per lane: there the branchless binary search (sampling.h, last_at_most) reads
// log2(n) of them instead of n.
lane_int count_at_most(__global const float* table, lane_int at, int n, lane_float u) {
#if LANES == 1
    lane_int count = 0;
    for (int i = 1; i < n; i++) count += select((lane_int)(0), (lane_int)(1), LANE_LOAD(table, at + i, ) <= u);
    return count;
#else
    return last_at_most(table, at, n, u);
#endif
}

// The same over one block of a CDF, table[at + 1 .. at + ENV_CDF_BLOCK - 1], of which only the
// entries before at + within belong to it (a CDF's last, short block). At at + within is the
// CDF's final 1, above every u < 1: the binary search reads it in place of any entry beyond.
lane_int count_block_at_most(__global const float* table, lane_int at, lane_int within, lane_float u) {
#if LANES == 1
    lane_int count = 0;
    for (int i = 1; i < ENV_CDF_BLOCK; i++)
        count += select((lane_int)(0), (lane_int)(1), (i < within) & (LANE_LOAD(table, at + min(i, within - 1), ) <= u));
    return count;
#else
    lane_int lo = 0;
    for (int len = ENV_CDF_BLOCK; len > 1;) {
        int step = len >> 1;
        lo = select(lo, lo + step, LANE_LOAD(table, at + min(lo + step, within), ) <= u);
        len -= step;
    }
    return lo;
#endif
}

// The last i < n with cdf[i] <= u in the CDF at `cdf` (n + 1 entries, non-decreasing, cdf[0] <= u)
// whose blocks start at `block_starts`, and u rescaled within i's interval (sample reuse).
lane_int sample_blocked_cdf_reuse(__global const float* table, lane_int cdf, lane_int block_starts, int n,
                                  lane_float u, lane_float* rescaled) {
#if LANES > 1
    prefetch_cdf_entries(table, block_starts, env_cdf_blocks(n));
#endif
    lane_int first = count_at_most(table, block_starts, env_cdf_blocks(n), u) * ENV_CDF_BLOCK;
#if LANES > 1
    prefetch_cdf_entries(table, cdf + first, ENV_CDF_BLOCK + 1);
#endif
    lane_int i = first + count_block_at_most(table, cdf + first, n - first, u);
    *rescaled = cdf_rescaled(u, LANE_LOAD(table, cdf + i, ), LANE_LOAD(table, cdf + i + 1, ));
    return i;
}

// Solid-angle density of grid cell (i, j) at a direction sin_theta from the pole: the cell's
// probability times the grid's cell count is its (u, v) density, and d(u, v) / d(omega) is
// 1 / (2 pi^2 sin theta).
lane_float environment_cell_pdf_w(const Scene* scene, int2 grid, lane_int i, lane_int j, lane_float sin_theta) {
    __global const float* table = scene->env_cdf;
    lane_int marginal = ENVIRONMENT_MARGINAL + j, conditional = environment_conditional(grid, j) + i;
    lane_float pdf_uv = (float)(grid.x * grid.y) * (LANE_LOAD(table, marginal + 1, ) - LANE_LOAD(table, marginal, )) *
                        (LANE_LOAD(table, conditional + 1, ) - LANE_LOAD(table, conditional, ));
    return select((lane_float)(0.0f), pdf_uv / (2.0f * PI_F * PI_F * sin_theta), sin_theta > 0.0f);
}

lane_float environment_pdf_uv_w(const Scene* scene, lane_float2 uv, lane_float sin_theta) {
    int2 grid = environment_sampling_grid(scene);
    lane_int i = min(lane_float_to_int(uv.x * (float)grid.x), (lane_int)(grid.x - 1));
    lane_int j = min(lane_float_to_int(uv.y * (float)grid.y), (lane_int)(grid.y - 1));
    return environment_cell_pdf_w(scene, grid, i, j, sin_theta);
}

lane_float3 environment_radiance(const Scene* scene, lane_float3 dir) {
    lane_float sin_theta;
    return environment_radiance_at(scene, direction_to_latlong(scene, environment_to_map(scene, dir), &sin_theta));
}

// The radiance along a direction and the solid-angle pdf of sampling it (an escaped ray under
// MIS): its (u, v) found once.
lane_float3 environment_radiance_pdf_w(const Scene* scene, lane_float3 dir, lane_float* pdf_w) {
    lane_float sin_theta;
    lane_float2 uv = direction_to_latlong(scene, environment_to_map(scene, dir), &sin_theta);
    *pdf_w = environment_pdf_uv_w(scene, uv, sin_theta);
    return environment_radiance_at(scene, uv);
}

// Piecewise-constant inversion over the sampling grid: a row from the marginal CDF, then a
// column in that row. The drawn cell gives the pdf and *uv the radiance
// (environment_radiance_at), with no way back from the direction.
lane_float3 sample_environment_direction(const Scene* scene, lane_float2 u, lane_float* pdf_w, lane_float2* uv) {
    int2 grid = environment_sampling_grid(scene);
    __global const float* table = scene->env_cdf;
    lane_float in_row, in_column;
    lane_int j = sample_blocked_cdf_reuse(table, (lane_int)(ENVIRONMENT_MARGINAL), environment_block_starts(grid, (lane_int)(-1)),
                                          grid.y, u.x, &in_row);
    lane_int i = sample_blocked_cdf_reuse(table, environment_conditional(grid, j), environment_block_starts(grid, j),
                                          grid.x, u.y, &in_column);
    *uv = make_lane_float2((lane_int_to_float(i) + in_column) / (float)grid.x,
                           clamp((lane_int_to_float(j) + in_row) / (float)grid.y, 0.0f, 1.0f));
    lane_float sin_theta, cos_theta, sin_phi, cos_phi;
    sincos_2pi(0.5f * uv->y, &sin_theta, &cos_theta);   // theta = v pi: half a turn
    sincos_2pi(uv->x - environment_u_offset(scene), &sin_phi, &cos_phi);
    sin_theta = fmax(sin_theta, 0.0f);
    *pdf_w = environment_cell_pdf_w(scene, grid, i, j, sin_theta);
    return environment_from_map(scene, make_lane_float3(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi));
}
#elif ENVIRONMENT == ENVIRONMENT_CONSTANT
lane_float3 environment_radiance(const Scene* scene, lane_float3 dir) {
    return l3_uniform(scene->emitters[scene->params->environment.x].radiance.xyz);
}

lane_float3 environment_radiance_pdf_w(const Scene* scene, lane_float3 dir, lane_float* pdf_w) {
    *pdf_w = UNIFORM_SPHERE_PDF_W;
    return environment_radiance(scene, dir);
}

lane_float3 environment_radiance_at(const Scene* scene, lane_float2 uv) {
    return l3_uniform(scene->emitters[scene->params->environment.x].radiance.xyz);
}

lane_float3 sample_environment_direction(const Scene* scene, lane_float2 u, lane_float* pdf_w, lane_float2* uv) {
    *pdf_w = UNIFORM_SPHERE_PDF_W;
    *uv = u;
    return sample_uniform_sphere(u);
}
#endif

// Radiance from the environment along an escaped ray (none without one); the MIS weight uses the
// pdf with which the previous vertex sampled this direction (none where that was a delta lobe).
lane_float3 escaped_radiance(const Scene* scene, lane_float3 dir, lane_float prev_pdf_w, lane_int prev_delta) {
#if ENVIRONMENT != ENVIRONMENT_NONE
    if (lane_all(prev_delta)) return environment_radiance(scene, dir);   // no MIS behind delta lobes
    lane_float pdf_w;
    lane_float3 le = environment_radiance_pdf_w(scene, dir, &pdf_w);
    lane_float light_pdf_w = emitter_selection_pmf(scene, (lane_int)(scene->params->environment.x)) * pdf_w;
    return l3_scale(le, select(power_heuristic(prev_pdf_w, light_pdf_w), (lane_float)(1.0f), prev_delta != 0));
#else
    return l3_splat(0.0f);
#endif
}

#endif
