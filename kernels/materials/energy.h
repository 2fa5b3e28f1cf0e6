// Energy compensation of the single-scattering microfacet lobes. Walter et al.'s BSDF counts
// light that meets one microfacet; light masked by the surface's own relief is lost, although in
// reality it scatters again and mostly leaves: at alpha = 1 a GGX mirror keeps 31% of the light at
// normal incidence, and rough glass seen from inside keeps 42%. A lossless rough sphere would show
// as a dark ball in a furnace. Following Turquin ("Practical multiple scattering compensation for
// microfacet models", 2019), the lobe is scaled by a function of wo only:
//   dielectric: f / E(mu_o), where E is the directional albedo, reflection plus transmission;
//   conductor:  f (1 + tint (1 - E(mu_o)) / E(mu_o)), with E the albedo of a white mirror.
// The scaled dielectric conserves energy exactly (up to the table's accuracy); the scaling keeps
// the lobe's shape and its sampling, but is not reciprocal (fine for a camera path tracer).
//
// E is tabulated per material and side (wo outside, wo inside) at ALBEDO_TABLE_SIZE values of
// mu_o, spaced in sqrt(mu_o) because E changes fastest near grazing; the host fills the tables
// with specular_albedo_table below, so they come from the very code that renders.
#ifndef CLRENDER_ENERGY_H
#define CLRENDER_ENERGY_H
#include "portability.h"
#include "materials/material.h"
#include "materials/microfacet.h"
#include "materials/dielectric.h"
#if DIELECTRIC

// ALBEDO_TABLE_SIZE comes from clrender/layout.py.
#ifndef ALBEDO_GRID          // (tests/test_oclgrind.py shrinks it: the simulator is slow)
#define ALBEDO_GRID 192      // u-grid per table entry: ALBEDO_GRID^2 visible normals
#endif

float albedo_table_mu(int k) {
    float s = (float)k / (float)(ALBEDO_TABLE_SIZE - 1);
    return fmax(s * s, 1e-4f);  // at mu = 0 exactly the masking ratio G2 / G1 is 0 / 0
}

// Linear interpolation in sqrt(mu).
float lookup_albedo(__global const float* table, float cos_o) {
    float x = sqrt(clamp(cos_o, 0.0f, 1.0f)) * (float)(ALBEDO_TABLE_SIZE - 1);
    int i = min((int)x, ALBEDO_TABLE_SIZE - 2);
    float t = x - (float)i;
    return table[i] * (1.0f - t) + table[i + 1] * t;
}

// E(mu_o) of the uncompensated lobe, as the exact expectation of sample_dielectric's (or
// sample_conductor's) energy weight over a midpoint grid of its random numbers: for each visible
// normal both lobes are summed with their Fresnel probabilities instead of picking one, and a
// valid sample weighs G2 / G1(wo) (eval / pdf without tint and the radiance 1/eta^2).
float specular_albedo(bool dielectric, float eta, float alpha, float cos_o) {
    float3 n = (float3)(0.0f, 0.0f, 1.0f);
    float3 wo = (float3)(sqrt(fmax(0.0f, 1.0f - cos_o * cos_o)), 0.0f, cos_o);
    float g1 = ggx_g1(cos_o, alpha);
    float sum = 0.0f;
    for (int j = 0; j < ALBEDO_GRID; ++j) {
        float row = 0.0f;  // summed per row, so float rounding stays small
        for (int i = 0; i < ALBEDO_GRID; ++i) {
            float2 u = (float2)(((float)i + 0.5f) / ALBEDO_GRID, ((float)j + 0.5f) / ALBEDO_GRID);
            float3 h = sample_ggx_vndf(n, wo, alpha, u);
            float cos_oh = dot(wo, h);
            if (cos_oh <= 0.0f) continue;
            float f = dielectric ? fresnel_dielectric(cos_oh, eta) : 1.0f;
            float3 wi = reflect(wo, h);
            if (wi.z > 0.0f) row += f * ggx_g2(cos_o, wi.z, alpha);
            if (f < 1.0f && refract(wo, h, eta, &wi) && wi.z < 0.0f)
                row += (1.0f - f) * ggx_g2(cos_o, wi.z, alpha);
        }
        sum += row;
    }
    return g1 > 0.0f ? sum / (g1 * (float)(ALBEDO_GRID * ALBEDO_GRID)) : 0.0f;
}

// Fills the tables of one material: global size (2, ALBEDO_TABLE_SIZE); side 0 has wo outside
// (eta = ior / exterior_ior), side 1 inside. A conductor has only side 0.
KERNEL void specular_albedo_table(__global const Material* materials, int material,
                                  __global float* tables) {
    int side = get_global_id(0), k = get_global_id(1);
    Material m = materials[material];
    bool dielectric = material_kind(&m) == MATERIAL_DIELECTRIC;
    int offset = material_albedo_tables(&m);
    if (offset < 0 || (!dielectric && side > 0)) return;
    float ior = material_ior(&m), exterior = material_exterior_ior(&m);
    float eta = side == 0 ? ior / exterior : exterior / ior;
    tables[offset + side * ALBEDO_TABLE_SIZE + k] =
        specular_albedo(dielectric, eta, material_alpha(&m), albedo_table_mu(k));
}

#endif
#endif
