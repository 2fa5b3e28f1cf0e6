// Light tracing of caustics: which paths the light paths (light_paths.cl) take from the path
// tracer. Read as events, from the light: one or more delta events (a smooth dielectric's or
// conductor's lobe), then a non-delta one, then anything, ending at a camera whose primary
// vertex scatters by a non-delta event (the light path joins the camera there). A path tracer
// finds these only by BSDF samples that happen to pass the delta surfaces and meet the light
// (caustics through glass: the fireflies of Veach's bidirectional scene); a light path finds
// them by construction. The path tracer leaves their emission out, so each path is counted by
// one technique, no MIS. Only from emitting triangles without a texture (what the light paths
// start from), and only where RenderParams.light_paths.x says so (clrender decides).
#ifndef CLRENDER_LIGHT_PATHS_H
#define CLRENDER_LIGHT_PATHS_H
#include "lanes.h"
#include "scene.h"

// What a camera path knows of its events: whether its primary one was non-delta, and the delta
// events since its last non-delta one (-1: none yet).
typedef struct { lane_int primary_smooth; lane_int delta_run; } CausticEvents;

CausticEvents caustic_events_none(void) {
    CausticEvents e;
    e.primary_smooth = 0;
    e.delta_run = -1;
    return e;
}

// After the camera path's event at `depth` (delta: a comparison's result).
void caustic_events_add(CausticEvents* e, int depth, lane_int delta) {
    if (depth == 1) e->primary_smooth = !delta;
    e->delta_run = select((lane_int)(0), select((lane_int)(-1), e->delta_run + 1, e->delta_run >= 0), delta);
}

// Whether the light paths take the emission of `emitter` (>= 0) that a camera path with events
// `e` has reached.
lane_int light_paths_take(const Scene* scene, const CausticEvents* e, lane_int emitter) {
    if (scene->params->light_paths.x == 0) return 0;
    lane_int index = max(emitter, (lane_int)(0));
    return e->primary_smooth & (e->delta_run >= 1) & (emitter >= 0) &
           (LANE_LOAD_INT(scene->emitters, index, .kind.x) == EMITTER_TRIANGLE) &
           (LANE_LOAD(scene->emitters, index, .radiance.w) < 0.0f);
}

#endif
