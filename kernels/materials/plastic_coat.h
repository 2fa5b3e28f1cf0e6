// The coat of plastic (materials/plastic.h): a dielectric interface over a diffuse base, seen
// through two numbers. Its transmittance T(mu) is the fraction of light arriving at cos(theta) =
// mu that crosses it (into the coat, or out of it, by reciprocity); its internal reflectance r is
// the fraction of the light that the base scatters up (uniformly in projected solid angle) which
// the coat's inside reflects back down. Both are Mitsuba 3.9's:
//   smooth coat (`plastic`): T = 1 - F(mu), r = Mitsuba's fit of the diffuse Fresnel reflectance
//     of the inside (fresnel_diffuse_reflectance(1 / eta), below);
//   rough coat (`roughplastic`): tables, computed as Mitsuba's parameters_changed computes them
//     at load time: T at COAT_TABLE_SIZE values mu_k = max(1e-6, k / (COAT_TABLE_SIZE - 1)),
//     looked up with linear interpolation (its lerp_gather), and r = 2 mean_k(R(mu_k) mu_k),
//     R the reflectance of the inside (eta inverted) at the same mu_k. T and R are Mitsuba's
//     eval_transmittance and eval_reflectance: the expectation over visible normals m of wi of
//     (1 - F) G1(wt) or F G1(wr), integrated by Gauss-Legendre quadrature over the random numbers
//     of visible-normal sampling (32^2 nodes for an interface of eta > 1, else 128^2).
// The host fills the tables with plastic_coat_table below (clrender/plastic.py): from the
// microfacet code that renders. A row holds T(mu_0..), then r; a textured alpha has rows
// spanning the texture's values (Material fields coat_alpha_range, coat_alpha_rows), evenly
// spaced in sqrt(alpha) and interpolated linearly there (T changes fastest at small alphas;
// Mitsuba has no textured alpha on roughplastic: docs/materials-plastic.md measures the error).
// Rows start at alpha 1e-4 at least (Mitsuba's least microfacet width).
#ifndef CLRENDER_PLASTIC_COAT_H
#define CLRENDER_PLASTIC_COAT_H
#include "portability.h"
#include "math.h"
#include "scene.h"
#include "materials/material.h"
#include "materials/microfacet.h"
#include "materials/dielectric_smooth.h"
#if DIELECTRIC

#define COAT_ROW (COAT_TABLE_SIZE + 1)
#ifndef COAT_NODES          // (tests/test_oclgrind.py shrinks it: the simulator is slow)
#define COAT_NODES 128      // the most quadrature nodes per axis a table entry uses
#endif

// Over the lane types (lanes.h): each lane its coat.
typedef struct {
    lane_float eta;                // n(coat) / n(outside)
    lane_int smooth;
    __global const float* tables;  // the scene's specular_albedo
    lane_int row;                  // rough: the index in tables of the row at or below alpha
    lane_int next;                 // floats from that row to the next (0: one row)
    lane_float next_weight;        // linear interpolation weight of the next row
} PlasticCoat;

// Mitsuba's fresnel_diffuse_reflectance: the diffuse Fresnel reflectance of an interface of
// relative index eta, by the fits of Egan and Hilgeman (eta < 1) and d'Eon and Irving.
lane_float fresnel_diffuse_reflectance(lane_float eta) {
    lane_float x = 1.0f / eta;
    return select(0.919317f + x * (-3.4793f + x * (6.75335f + x * (-7.80989f + x * (4.98554f + x * -1.36881f)))),
                  0.0636f * x + (eta * (eta * -1.4399f + 0.7099f) + 0.6681f), eta < 1.0f);
}

// The coat of relative index eta whose tables start at `offset` in the scene's specular_albedo
// (< 0: smooth, no tables), `rows` rows spanning the alpha range `range`, at alpha.
PlasticCoat make_plastic_coat(const Scene* scene, lane_float eta, lane_int offset, lane_float2 range, lane_int rows,
                              lane_float alpha) {
    PlasticCoat c;
    c.eta = eta;
    c.smooth = offset < 0;
    c.tables = scene->specular_albedo;
    c.row = max(offset, (lane_int)(0));
    c.next = 0;
    c.next_weight = 0.0f;
    lane_int interpolated = !c.smooth & (rows > 1);
    if (lane_any(interpolated)) {
        lane_float low = sqrt(range.x), high = sqrt(range.y);
        lane_float x = clamp((sqrt(alpha) - low) / (high - low), 0.0f, 1.0f) * lane_int_to_float(rows - 1);
        lane_int r = min(lane_float_to_int(x), rows - 2);
        c.row = select(c.row, c.row + r * COAT_ROW, interpolated);
        c.next = select(c.next, (lane_int)(COAT_ROW), interpolated);
        c.next_weight = select(c.next_weight, x - lane_int_to_float(r), interpolated);
    }
    return c;
}

#if LANES == 1
// The coat of material m (its textures resolved) at alpha: smooth without tables (Mitsuba's
// plastic; also a rough one that no shape uses).
PlasticCoat plastic_coat(const Scene* scene, const Material* m, float alpha) {
    return make_plastic_coat(scene, material_ior(m) / material_exterior_ior(m), material_albedo_tables(m),
                             material_coat_alpha_range(m), material_coat_alpha_rows(m), alpha);
}
#endif

// The same, of each lane's material `index` where `plastic` (the others: smooth, reading no table).
PlasticCoat plastic_coat_at(const Scene* scene, lane_int index, lane_int plastic, lane_float alpha) {
    lane_int offset = select((lane_int)(-1), material_albedo_tables_at(scene->materials, index), plastic);
    return make_plastic_coat(scene, material_ior_at(scene->materials, index) /
                             material_exterior_ior_at(scene->materials, index), offset,
                             material_coat_alpha_range_at(scene->materials, index),
                             material_coat_alpha_rows_at(scene->materials, index), alpha);
}

// Entry k of the coat's row, interpolated in alpha (rough lanes).
lane_float coat_entry(const PlasticCoat* c, lane_int k) {
    return LANE_LOAD(c->tables, c->row + k, ) * (1.0f - c->next_weight) +
           LANE_LOAD(c->tables, c->row + k + c->next, ) * c->next_weight;
}

lane_float coat_transmittance(const PlasticCoat* c, lane_float mu) {
    lane_float t = 0.0f;
    if (lane_any(c->smooth)) t = 1.0f - fresnel_dielectric(mu, c->eta);
    lane_int rough = !c->smooth;
    if (lane_any(rough)) {
        lane_float x = clamp(mu, 0.0f, 1.0f) * (float)(COAT_TABLE_SIZE - 1);
        lane_int k = min(lane_float_to_int(x), (lane_int)(COAT_TABLE_SIZE - 2));
        lane_float w = x - lane_int_to_float(k);
        t = select(t, (1.0f - w) * coat_entry(c, k) + w * coat_entry(c, k + 1), rough);
    }
    return t;
}

lane_float coat_internal_reflectance(const PlasticCoat* c) {
    lane_float r = 0.0f;
    if (lane_any(c->smooth)) r = fresnel_diffuse_reflectance(1.0f / c->eta);
    lane_int rough = !c->smooth;
    if (lane_any(rough)) r = select(r, coat_entry(c, (lane_int)(COAT_TABLE_SIZE)), rough);
    return r;
}

#if LANES == 1   // the tables' kernel (kernels/tables.cl)
// Mitsuba's eval_transmittance (reflection false) or eval_reflectance (true) of a rough
// interface of relative index eta, for light arriving at cos(theta) = mu; nodes: (x, weight) of
// the Gauss-Legendre rule on [-1, 1].
float coat_quadrature(bool reflection, float eta, Microfacet mf, float mu, __global const float2* nodes,
                      int count) {
    float3 n = (float3)(0.0f, 0.0f, 1.0f);
    float3 wi = (float3)(sqrt(fmax(0.0f, 1.0f - mu * mu)), 0.0f, mu);
    count = min(count, COAT_NODES);
    float sum = 0.0f;
    for (int j = 0; j < count; ++j) {
        float row = 0.0f;  // summed per row, so float rounding stays small
        for (int i = 0; i < count; ++i) {
            float2 u = (float2)(nodes[i].x, nodes[j].x) * 0.5f + 0.5f;
            float3 m = sample_microfacet_visible(mf, n, wi, u);
            float f = fresnel_dielectric(dot(wi, m), eta);
            float3 wo = wi;
            float value = 0.0f;
            if (reflection) {
                wo = reflect(wi, m);
                if (wo.z > 0.0f) value = f * microfacet_g1(mf, wo.z);
            } else if (f < 1.0f && refract(wi, m, eta, &wo) && wo.z < 0.0f) {
                value = (1.0f - f) * microfacet_g1(mf, wo.z);
            }
            row += value * nodes[i].y;
        }
        sum += row * nodes[j].y;
    }
    return 0.25f * sum;
}

// One entry of the coat tables of materials[material]: global size (rows, 2, COAT_TABLE_SIZE);
// out[(r * 2 + 0) * COAT_TABLE_SIZE + k] = T(mu_k) at row r's alpha, [(r * 2 + 1) ...] = R(mu_k)
// of the inside, which the host reduces to the internal reflectance. nodes_32, nodes_128: the
// Gauss-Legendre rules of 32 and 128 nodes.
KERNEL void plastic_coat_table(__global const Material* materials, int material,
                               __global const float2* nodes_32, __global const float2* nodes_128,
                               __global float* out) {
    int r = get_global_id(0), side = get_global_id(1), k = get_global_id(2);
    int rows = get_global_size(0);
    Material m = materials[material];
    float2 range = material_coat_alpha_range(&m);
    float alpha = range.x;
    if (rows > 1) {
        float s = sqrt(range.x) + (sqrt(range.y) - sqrt(range.x)) * (float)r / (float)(rows - 1);
        alpha = s * s;
    }
    float eta = material_ior(&m) / material_exterior_ior(&m);
    if (side == 1) eta = 1.0f / eta;
    float mu = fmax(1e-6f, (float)k / (float)(COAT_TABLE_SIZE - 1));
    bool fine = !(eta > 1.0f);
    out[(r * 2 + side) * COAT_TABLE_SIZE + k] =
        coat_quadrature(side == 1, eta, make_microfacet(alpha, material_distribution(&m), MASKING_SEPARABLE), mu,
                        fine ? nodes_128 : nodes_32, fine ? 128 : 32);
}

#endif
#endif
#endif
