// The caustic guide (clrender/guide.py): for the cells of a grid, the directions from which light
// that crossed specular or glossy surfaces (photons, guide_photons.cl) reached a diffuse surface
// there, as up to GUIDE_LOBES cones, each with its share of that light. Diffuse sampling
// (materials/diffuse.h) draws RenderParams.guide_cone.x of its directions from the cones of the
// cell it is in and the rest from the cosine, weighed by the mixture's density: the image does not
// depend on the guide, only its noise (a cone that points nowhere costs samples, not correctness).
// Light through rough glass from a directional light reaches a diffuse point only from a few
// narrow cones; cosine sampling finds them by chance, as rare and bright samples.
#ifndef CLRENDER_GUIDE_H
#define CLRENDER_GUIDE_H
#include "lanes.h"
#include "math.h"
#include "types.h"
#include "scene.h"

// The index of the first lobe of the guide cell holding p, or -1 where p lies outside the grid
// or the scene has no guide.
lane_int guide_cell_lobes(const Scene* scene, lane_float3 p) {
    __constant RenderParams* params = scene->params;
    if (params->guide_cells.w == 0) return (lane_int)(-1);
    float4 grid = params->guide_grid;
    int4 cells = params->guide_cells;
    lane_float x = floor((p.x - grid.x) * grid.w), y = floor((p.y - grid.y) * grid.w), z = floor((p.z - grid.z) * grid.w);
    lane_int inside = (x >= 0.0f) & (x < (float)cells.x) & (y >= 0.0f) & (y < (float)cells.y) & (z >= 0.0f) &
                      (z < (float)cells.z);
    // Clamped before the conversion: a point far outside would overflow an int.
    lane_int ix = lane_float_to_int(clamp(x, 0.0f, (float)(cells.x - 1)));
    lane_int iy = lane_float_to_int(clamp(y, 0.0f, (float)(cells.y - 1)));
    lane_int iz = lane_float_to_int(clamp(z, 0.0f, (float)(cells.z - 1)));
    lane_int first = ((iz * cells.y + iy) * cells.x + ix) * GUIDE_LOBES;
    // An empty cell's lobes weigh nothing (their cumulative weight stays 0).
    inside &= LANE_LOAD(scene->guide, first + (GUIDE_LOBES - 1), .direction.w) > 0.0f;
    return select((lane_int)(-1), first, inside);
}

// The guide's density (per steradian) of direction wi in the cell whose lobes start at `first`:
// each cone's share over its solid angle, where wi lies in it (0 where first is -1).
lane_float guide_pdf_w(const Scene* scene, lane_int first, lane_float3 wi) {
    lane_int guided = first >= 0;
    first = max(first, 0);
    float cos_cone = scene->params->guide_cone.y, inv_solid_angle = scene->params->guide_cone.z;
    lane_float density = 0.0f, below = 0.0f;
    for (int k = 0; k < GUIDE_LOBES; ++k) {
        lane_float cumulative = LANE_LOAD(scene->guide, first + k, .direction.w);
        lane_float3 axis = LANE_LOAD3(scene->guide, first + k, .direction);
        density += select((lane_float)(0.0f), cumulative - below, l3_dot(wi, axis) >= cos_cone);
        below = cumulative;
    }
    return select((lane_float)(0.0f), density * inv_solid_angle, guided);
}

// A direction from the guide's cones in the cell whose lobes start at `first` (cell 0's where
// first is -1): u.x picks the cone by the lobes' cumulative weights and, rescaled within its
// share, the angle from the axis (uniform in solid angle); u.y the turn around it.
lane_float3 sample_guide(const Scene* scene, lane_int first, lane_float2 u) {
    first = max(first, 0);
    lane_float below = 0.0f, share = 1.0f, chosen_below = 0.0f;
    lane_float3 axis = l3_splat(0.0f);
    lane_int found = 0 != 0;
    for (int k = 0; k < GUIDE_LOBES; ++k) {
        lane_float cumulative = LANE_LOAD(scene->guide, first + k, .direction.w);
        lane_int here = !found & (u.x < cumulative);
        axis = l3_select(axis, LANE_LOAD3(scene->guide, first + k, .direction), here);
        chosen_below = select(chosen_below, below, here);
        share = select(share, cumulative - below, here);
        found |= here;
        below = cumulative;
    }
    lane_float t = clamp((u.x - chosen_below) / share, 0.0f, 1.0f);
    float cos_cone = scene->params->guide_cone.y;
    lane_float cos_theta = 1.0f - t * (1.0f - cos_cone);
    lane_float sin_theta = sqrt(fmax(0.0f, 1.0f - cos_theta * cos_theta));
    lane_float s, c;
    sincos_2pi(u.y, &s, &c);
    return to_world(make_lane_float3(sin_theta * c, sin_theta * s, cos_theta), axis);
}

#endif
