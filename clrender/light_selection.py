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
"""
import numpy as np


def selection_weights(powers, areas, groups):
    """Unnormalised selection probabilities of the emitters with `powers`, `areas` (any positive
    number for a light that is not a mesh) and `groups` (the shape a triangle belongs to; one
    group per sphere and per light)."""
    powers, areas, groups = (np.asarray(a, dtype=float) for a in (powers, areas, groups))
    if len(powers) == 0:
        return powers
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
