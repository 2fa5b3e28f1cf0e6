// Point, spot and directional lights (delta lights: no area, reached by light samples only), over
// the lane types (lanes.h): the light each arriving at a point.
#ifndef CLRENDER_DELTA_LIGHTS_H
#define CLRENDER_DELTA_LIGHTS_H
#include "lanes.h"
#include "types.h"
#include "math.h"

// Mitsuba's spot falloff of spot light `index` along the unit direction d from the light: 1
// within the beam width, then linear in the angle down to 0 at the cutoff angle, and 0 beyond
// (both tests on cosines, as Mitsuba makes them). acos only where some lane is in the transition.
lane_float spot_falloff(__global const Emitter* emitters, lane_int index, lane_float3 d) {
    lane_float cos_theta = l3_dot(d, LANE_LOAD3(emitters, index, .e1));
    lane_int inside = cos_theta > LANE_LOAD(emitters, index, .e1.w);
    lane_int full = cos_theta >= LANE_LOAD(emitters, index, .e2.x);
    lane_float falloff = select((lane_float)(0.0f), (lane_float)(1.0f), inside & full);
    lane_int edge = inside & !full;
    if (lane_any(edge))
        falloff = select(falloff, (LANE_LOAD(emitters, index, .e2.y) - acos(cos_theta)) * LANE_LOAD(emitters, index, .e2.z),
                         edge);
    return falloff;
}

// The light of emitter `index` arriving at p where it is a point, spot or directional light: the
// unit direction *wi to it, the distance *dist and *radiance ((0, 0, 1), infinity and 0 in the
// other lanes); a mask of the lanes it arrives in (not other kinds, nor a point or spot light at p).
lane_int delta_light_arriving(__global const Emitter* emitters, lane_int index, lane_float3 p, lane_float3* wi,
                              lane_float* dist, lane_float3* radiance) {
    lane_int kind = LANE_LOAD_INT(emitters, index, .kind.x);
    lane_int spot = kind == EMITTER_SPOT, positioned = (kind == EMITTER_POINT) | spot;
    lane_int directional = kind == EMITTER_DIRECTIONAL;
    lane_float3 le = LANE_LOAD3(emitters, index, .radiance);
    lane_float3 w = make_lane_float3((lane_float)(0.0f), (lane_float)(0.0f), (lane_float)(1.0f));
    lane_float d = INFINITY;
    lane_float3 r = l3_splat(0.0f);
    if (lane_any(positioned)) {
        lane_float3 to_light = l3_sub(LANE_LOAD3(emitters, index, .p0), p);
        lane_float dist2 = l3_dot(to_light, to_light);
        positioned &= dist2 > 0.0f;
        lane_float light_dist = sqrt(dist2);
        lane_float3 light_wi = l3_div(to_light, light_dist);
        lane_float3 light_radiance = l3_div(le, dist2);
        spot &= positioned;
        if (lane_any(spot))
            light_radiance = l3_select(light_radiance,
                                       l3_scale(light_radiance, spot_falloff(emitters, index, l3_neg(light_wi))), spot);
        w = l3_select(w, light_wi, positioned);
        d = select(d, light_dist, positioned);
        r = l3_select(r, light_radiance, positioned);
    }
    if (lane_any(directional)) {
        w = l3_select(w, LANE_LOAD3(emitters, index, .p0), directional);
        r = l3_select(r, le, directional);
    }
    *wi = w;
    *dist = d;
    *radiance = r;
    return positioned | directional;
}

#endif
