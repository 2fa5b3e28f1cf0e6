// Named accessors of the packed Material record: the only kernel code that knows its lanes.
// The lanes are defined once, in clrender/layout.py (MATERIAL_FIELDS, beside the dtype), where
// their meaning is documented; tests/test_layout.py checks every accessor against that table.
#ifndef CLRENDER_MATERIAL_H
#define CLRENDER_MATERIAL_H
#include "lanes.h"
#include "types.h"

// The slots of the texturable parameters the packets look up (textured_params.h).
#define MATERIAL_COLOR_SLOT 0
#define MATERIAL_OPACITY_SLOT 12

int material_kind(const Material* m) { return m->kind.x; }
int material_one_sided(const Material* m) { return m->kind.y; }
int material_back_material(const Material* m) { return m->kind.z; }
int material_albedo_tables(const Material* m) { return m->kind.w; }
int material_normal_map(const Material* m) { return m->maps.x; }
int material_bump_map(const Material* m) { return m->maps.y; }
int material_distribution(const Material* m) { return m->maps.z; }
int material_masking(const Material* m) { return m->maps.w; }
int material_masked(const Material* m) { return (int)m->slot[MATERIAL_OPACITY_SLOT].z; }
float3 material_emission(const Material* m) { return m->emission.xyz; }
float3 material_color(const Material* m) { return m->slot[MATERIAL_COLOR_SLOT].xyz; }
float material_alpha(const Material* m) { return m->slot[1].x; }
float material_ior(const Material* m) { return m->slot[2].x; }
float material_exterior_ior(const Material* m) { return m->slot[2].y; }
float3 material_reflection_tint(const Material* m) { return m->slot[3].xyz; }
float3 material_conductor_eta(const Material* m) { return m->slot[4].xyz; }
float3 material_conductor_k(const Material* m) { return m->slot[5].xyz; }
int material_nonlinear(const Material* m) { return (int)m->slot[2].z; }
float material_specular_sampling_weight(const Material* m) { return m->slot[4].x; }
float2 material_coat_alpha_range(const Material* m) { return m->slot[4].yz; }
int material_coat_alpha_rows(const Material* m) { return (int)m->slot[5].x; }
float material_opacity(const Material* m) { return m->slot[MATERIAL_OPACITY_SLOT].x; }
float material_bump_scale(const Material* m) { return m->slot[12].y; }

float3 material_toon_shadow_color(const Material* m) { return m->slot[3].xyz; }
float material_toon_shadow_factor(const Material* m) { return m->slot[4].x; }
float material_toon_bands(const Material* m) { return m->slot[4].y; }
float material_toon_band_softness(const Material* m) { return m->slot[4].z; }
float material_toon_highlight_size(const Material* m) { return m->slot[5].x; }
float material_toon_highlight_softness(const Material* m) { return m->slot[5].y; }
float3 material_toon_highlight_color(const Material* m) { return m->slot[6].xyz; }
float material_toon_rim_width(const Material* m) { return m->slot[7].x; }
float3 material_toon_rim_color(const Material* m) { return m->slot[8].xyz; }
float material_toon_rim_threshold(const Material* m) { return m->slot[7].y; }
float3 material_toon_ambient(const Material* m) { return m->slot[9].xyz; }

float material_principled_roughness(const Material* m) { return m->slot[1].x; }
float material_principled_diffuse_rate(const Material* m) { return m->slot[1].y; }
float material_principled_eta(const Material* m) { return m->slot[2].x; }
float material_principled_specular_rate(const Material* m) { return m->slot[2].y; }
float material_principled_clearcoat_rate(const Material* m) { return m->slot[2].z; }
float material_principled_anisotropic(const Material* m) { return m->slot[3].x; }
float material_principled_metallic(const Material* m) { return m->slot[4].x; }
float material_principled_spec_trans(const Material* m) { return m->slot[5].x; }
float material_principled_spec_tint(const Material* m) { return m->slot[6].x; }
float material_principled_sheen(const Material* m) { return m->slot[7].x; }
float material_principled_sheen_tint(const Material* m) { return m->slot[8].x; }
float material_principled_clearcoat(const Material* m) { return m->slot[9].x; }
float material_principled_clearcoat_gloss(const Material* m) { return m->slot[10].x; }
float material_principled_flatness(const Material* m) { return m->slot[11].x; }

// The same fields of materials[index], for each lane's index (lanes.h).
lane_int material_kind_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD_INT(materials, index, .kind.x);
}
lane_int material_one_sided_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD_INT(materials, index, .kind.y);
}
lane_int material_masked_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD(materials, index, .slot[MATERIAL_OPACITY_SLOT].z) != 0.0f;
}
lane_float3 material_emission_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD3(materials, index, .emission);
}
lane_float material_ior_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD(materials, index, .slot[2].x);
}
lane_float material_exterior_ior_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD(materials, index, .slot[2].y);
}
lane_float3 material_conductor_eta_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD3(materials, index, .slot[4]);
}
lane_float3 material_conductor_k_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD3(materials, index, .slot[5]);
}
lane_float material_alpha_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD(materials, index, .slot[1].x);
}
lane_int material_distribution_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD_INT(materials, index, .maps.z);
}
lane_int material_masking_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD_INT(materials, index, .maps.w);
}
lane_float3 material_reflection_tint_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD3(materials, index, .slot[3]);
}
lane_int material_albedo_tables_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD_INT(materials, index, .kind.w);
}
lane_int material_nonlinear_at(__global const Material* materials, lane_int index) {
    return lane_float_to_int(LANE_LOAD(materials, index, .slot[2].z));
}
lane_float material_specular_sampling_weight_at(__global const Material* materials, lane_int index) {
    return LANE_LOAD(materials, index, .slot[4].x);
}
lane_float2 material_coat_alpha_range_at(__global const Material* materials, lane_int index) {
    return make_lane_float2(LANE_LOAD(materials, index, .slot[4].y), LANE_LOAD(materials, index, .slot[4].z));
}
lane_int material_coat_alpha_rows_at(__global const Material* materials, lane_int index) {
    return lane_float_to_int(LANE_LOAD(materials, index, .slot[5].x));
}

// An index-matched boundary (an interface, or a dielectric with the same index on both sides):
// only separates media and transmits its colour, not a path vertex.
bool material_is_interface(const Material* m) { return material_kind(m) == MATERIAL_INTERFACE; }
float3 material_boundary_transmittance(const Material* m) { return material_color(m); }

#endif
