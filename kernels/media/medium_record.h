// Named accessors of the packed Medium record: the only kernel code that knows its lanes. The
// lanes are defined once, in clrender/layout.py (MEDIUM_FIELDS, beside the dtype), where their
// meaning is documented; tests/test_layout.py checks every accessor against that table. (The
// member to_voxel, a 3x4 matrix, is read by world_to_voxel in media/grid.h.)
#ifndef CLRENDER_MEDIUM_RECORD_H
#define CLRENDER_MEDIUM_RECORD_H
#include "types.h"

float3 medium_sigma_a(__global const Medium* m) { return m->sigma_a.xyz; }
float3 medium_sigma_s(__global const Medium* m) { return m->sigma_s.xyz; }
float medium_g(__global const Medium* m) { return m->params.x; }
float medium_sample_emitters(__global const Medium* m) { return m->params.y; }
int medium_kind(__global const Medium* m) { return m->grid.x; }
int medium_voxel_offset(__global const Medium* m) { return m->grid.y; }
int medium_majorant_offset(__global const Medium* m) { return m->grid.z; }
int medium_majorant_block(__global const Medium* m) { return m->grid.w; }
int3 medium_resolution(__global const Medium* m) { return m->resolution.xyz; }
int3 medium_majorant_resolution(__global const Medium* m) { return m->majorant_resolution.xyz; }
int medium_albedo_offset(__global const Medium* m) { return m->albedo_grid.x; }
int medium_albedo_channels(__global const Medium* m) { return m->albedo_grid.y; }
int3 medium_albedo_resolution(__global const Medium* m) { return m->albedo_resolution.xyz; }

bool medium_makes_light_samples(__global const Medium* m) { return medium_sample_emitters(m) != 0.0f; }

bool medium_has_albedo_grid(__global const Medium* m) { return medium_albedo_channels(m) > 0; }

float3 medium_sigma_t(__global const Medium* m) { return medium_sigma_a(m) + medium_sigma_s(m); }

bool medium_is_grid(__global const Medium* m) { return medium_kind(m) == MEDIUM_GRID; }

#endif
