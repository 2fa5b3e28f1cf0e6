// Mitsuba's `mask` (TEXTURES=1): a surface stops the fraction `opacity` of the light that reaches
// it, from either side, and lets the rest pass straight through. A path passes with probability
// 1 - opacity, with weight 1 and no path vertex (as index-matched boundaries, path.h), else the
// material's BSDF acts, unscaled (its opacity cancels against the choice); shadow rays carry
// 1 - opacity across each masked surface (media/transport.h). Mitsuba's NEE treats masks as opaque
// and reaches lights behind them by BSDF sampling only: both are unbiased.
#ifndef CLRENDER_MASK_H
#define CLRENDER_MASK_H
#include "rng.h"
#include "materials/material.h"

#if TEXTURES
float mask_opacity(const Material* m) { return clamp(material_opacity(m), 0.0f, 1.0f); }

// Whether the path passes through the surface (draws a number only where it may).
bool passes_through_mask(const Material* m, Rng* rng) {
    float opacity = mask_opacity(m);
    return opacity < 1.0f && rng_float(rng) >= opacity;
}

float mask_transmittance(const Material* m) { return 1.0f - mask_opacity(m); }
#endif

#endif
