"""How next-event estimation picks an emitter: the weights of the CDF that kernels/lights.h draws
one emitter from (an emitting triangle or sphere, the environment, a point, spot or directional
light), and that the MIS weights of emission hit by BSDF samples read back.

Half of the probability goes by power, half as Mitsuba 3 picks: each emitting shape and each
light alike, then a point of a mesh by area. By power alone a small bright light beside a
powerful one is almost never picked, and the glossy highlights and diffuse light it casts come
from rare BSDF samples that hit it: fireflies (Veach's MIS scene, Mitsuba's
docs/scenes/integrator_direct_both.xml: 4 lights of power 1 beside one of 200, picked 0.5 % of
the time each). Uniform picking alone wastes samples on dim lights among bright ones. The
mixture's second moment is at most twice that of either (a defensive mixture: the sample weight
f / q is at most twice f / p of either part), so neither kind of scene is much worse than with
its better strategy.

The environment's power in the by-power half is a quarter of its power elsewhere (toon's shares):
4 pi^2 r^2 L is the flux into the scene's bounding sphere of radius r, which only a scene facing
all ways receives, while a directional light's pi r^2 E is what a disk facing it receives. A
shading point sees at most half the sky, irradiance pi L against the sun's E, so the quarter,
pi^2 r^2 L, weighs them as a surface facing each sees them. Counted whole, tests/mitsuba_scenes.py's
sky (radiance 0.4) took 57 % of the light samples beside its sun (irradiance 2.8), where Mitsuba
gives each half: sunlit floors were 1.4 times as noisy as Mitsuba's; with the quarter (the sky 41 %),
0.7-0.9 times (docs/performance.md, "Variance on the real scenes").
"""
import numpy as np


def selection_weights(powers, areas, groups, environment=-1):
    """Unnormalised selection probabilities of the emitters with `powers`, `areas` (any positive
    number for a light that is not a mesh) and `groups` (the shape a triangle belongs to; one
    group per sphere and per light); `environment`: the index of the environment, if any, whose
    power counts a quarter (see the module's docstring)."""
    powers, areas, groups = (np.array(a, dtype=float) for a in (powers, areas, groups))
    if len(powers) == 0:
        return powers
    if environment >= 0:
        powers[environment] *= 0.25
    _, group, group_count = np.unique(groups, return_inverse=True, return_counts=True)
    group_area = np.bincount(group, weights=areas)
    as_mitsuba = areas / group_area[group] / len(group_count)
    by_power = powers / powers.sum() if powers.sum() > 0 else as_mitsuba
    return 0.5 * by_power + 0.5 * as_mitsuba


def power_shares(powers):
    """Each emitter's share of the scene's light power (toon shading's p_j, kernels/types.h);
    equal shares where no emitter has power."""
    powers = np.asarray(powers, dtype=float)
    total = powers.sum()
    return powers / total if total > 0 else np.full(len(powers), 1.0 / max(len(powers), 1))
