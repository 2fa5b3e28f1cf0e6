// What the direct integrator (direct.h, direct_packets.h) takes from RenderParams.sampling: its
// light and BSDF sample counts (.y, .z; both 0 for path tracing).
#ifndef CLRENDER_DIRECT_SAMPLES_H
#define CLRENDER_DIRECT_SAMPLES_H
#include "scene.h"

bool direct_integrator(const Scene* scene) {
    return scene->params->sampling.y + scene->params->sampling.z > 0;
}

// Whether a BSDF sample can find emission at all: emitting shapes or an environment (point, spot
// and directional lights are never hit). Without, BSDF samples add exactly 0 and are not traced.
bool emission_can_be_hit(const Scene* scene) {
    return scene->params->lights.x > 0 || scene->params->environment.x >= 0;
}

#endif
