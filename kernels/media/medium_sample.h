// What the media estimators return to the integrator (media/medium.h): one record for every
// way of sampling a medium along a ray segment, so path.h never knows which estimator ran.
#ifndef CLRENDER_MEDIUM_SAMPLE_H
#define CLRENDER_MEDIUM_SAMPLE_H
#include "types.h"
#include "scene.h"

#define MEDIUM_EVENT_PASS 0      // the ray reached the end of the segment
#define MEDIUM_EVENT_SCATTER 1   // a real scattering at distance t: a new path vertex
#define MEDIUM_EVENT_ABSORB 2    // absorbed (delta tracking): the path ends

typedef struct {
    int event;
    float t;          // distance of the scattering; the segment's end otherwise
    float3 weight;    // throughput factor f / p of the segment, per channel
    float pdf_ratio;  // on a pass: the segment's transmittance pdf, unidirectional over light
                      // technique (media/transport.h, MIS); 1 otherwise
} MediumSample;

// Spectral MIS over the hero channel (RenderParams.media.y; off only for comparisons).
bool media_spectral_mis(const Scene* scene) { return scene->params->media.y != 0; }

#endif
