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

typedef struct {
    float eta;                  // n(coat) / n(outside)
    int smooth;
    __global const float* row;  // rough: the tables' row at or below alpha
    int next;                   // floats from that row to the next (0: one row)
    float next_weight;          // linear interpolation weight of the next row
} PlasticCoat;

// Mitsuba's fresnel_diffuse_reflectance: the diffuse Fresnel reflectance of an interface of
// relative index eta, by the fits of Egan and Hilgeman (eta < 1) and d'Eon and Irving.
float fresnel_diffuse_reflectance(float eta) {
    float x = 1.0f / eta;
    if (eta < 1.0f) return 0.0636f * x + (eta * (eta * -1.4399f + 0.7099f) + 0.6681f);
    return 0.919317f + x * (-3.4793f + x * (6.75335f + x * (-7.80989f + x * (4.98554f + x * -1.36881f))));
}

// The coat of material m (its textures resolved) at alpha: smooth without tables (Mitsuba's
// plastic; also a rough one that no shape uses).
PlasticCoat plastic_coat(const Scene* scene, const Material* m, float alpha) {
    PlasticCoat c;
    c.eta = material_ior(m) / material_exterior_ior(m);
    int offset = material_albedo_tables(m);
    c.smooth = offset < 0;
    c.row = scene->specular_albedo + max(offset, 0);
    c.next = 0;
    c.next_weight = 0.0f;
    float2 range = sqrt(material_coat_alpha_range(m));
    int rows = material_coat_alpha_rows(m);
    if (!c.smooth && rows > 1) {
        float x = clamp((sqrt(alpha) - range.x) / (range.y - range.x), 0.0f, 1.0f) * (float)(rows - 1);
        int r = min((int)x, rows - 2);
        c.row += r * COAT_ROW;
        c.next = COAT_ROW;
        c.next_weight = x - (float)r;
    }
    return c;
}

// Entry k of the coat's row, interpolated in alpha.
float coat_entry(const PlasticCoat* c, int k) {
    return c->row[k] * (1.0f - c->next_weight) + c->row[k + c->next] * c->next_weight;
}

float coat_transmittance(const PlasticCoat* c, float mu) {
    if (c->smooth) return 1.0f - fresnel_dielectric(mu, c->eta);
    float x = clamp(mu, 0.0f, 1.0f) * (float)(COAT_TABLE_SIZE - 1);
    int k = min((int)x, COAT_TABLE_SIZE - 2);
    float w = x - (float)k;
    return (1.0f - w) * coat_entry(c, k) + w * coat_entry(c, k + 1);
}

float coat_internal_reflectance(const PlasticCoat* c) {
    return c->smooth ? fresnel_diffuse_reflectance(1.0f / c->eta) : coat_entry(c, COAT_TABLE_SIZE);
}

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
