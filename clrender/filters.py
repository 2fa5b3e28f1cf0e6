"""Pixel reconstruction filters (camera.filter): Mitsuba 3's definitions, and the table with
which the kernel draws each camera sample's image position from its pixel's filter
(kernels/filter.h explains the sampling; docs/scene-format.md the parameters).

    box       each sample counts in its own pixel (radius 1/2)
    gaussian  exp(-t^2 / (2 stddev^2)) less its value at the radius, 4 stddev; Mitsuba's default
    tent      1 - |t| / radius

Offsets t are in pixels from the pixel's centre; the filters are separable, f(tx) f(ty), and
symmetric, f(-t) = f(t).
"""
import functools
import math

import numpy as np

from . import layout


def radius(f):
    """The filter's support: f(t) = 0 for |t| >= radius."""
    return {"box": 0.5, "gaussian": 4.0 * f.stddev, "tent": f.radius}[f.type]


def evaluate(f, t):
    """f(t) in float64, as Mitsuba's ReconstructionFilter.eval defines it (its gaussian evaluates
    exp to 4e-4 relative)."""
    t = np.abs(np.asarray(t, dtype=float))
    if f.type == "gaussian":
        alpha = -0.5 / f.stddev**2
        return np.maximum(np.exp(alpha * t * t) - math.exp(alpha * radius(f) ** 2), 0.0)
    if f.type == "tent":
        return np.maximum(1.0 - t / f.radius, 0.0)
    return np.where(t < 0.5, 1.0, 0.0)


def slope_at_radius(f):
    """f'(t) as t rises from -radius: where f leaves 0."""
    if f.type == "gaussian":
        return radius(f) / f.stddev**2 * math.exp(-0.5 * (radius(f) / f.stddev) ** 2)
    return 1.0 / f.radius   # tent


def cumulative(f, t):
    """The integral of f from -radius to t (t clamped to the support), in closed form."""
    r = radius(f)
    t = np.clip(np.asarray(t, dtype=float), -r, r)
    if f.type == "gaussian":
        scale = f.stddev * math.sqrt(2.0)
        erf = np.vectorize(math.erf)
        bias = math.exp(-0.5 * (r / f.stddev) ** 2)
        return f.stddev * math.sqrt(math.pi / 2) * (erf(t / scale) + math.erf(r / scale)) - bias * (t + r)
    if f.type == "tent":
        return np.where(t <= 0, (t + r) ** 2 / (2 * r), r - (r - t) ** 2 / (2 * r))
    return t + r


def _bisect(function, targets, low, high):
    """x in [low, high] with function(x) = targets (increasing function, vectorised; float64)."""
    targets = np.asarray(targets, dtype=float)
    low, high = np.full(targets.shape, float(low)), np.full(targets.shape, float(high))
    for _ in range(64):
        middle = (low + high) / 2
        below = function(middle) < targets
        low, high = np.where(below, middle, low), np.where(below, high, middle)
    return (low + high) / 2


def inverse_cumulative(f, p):
    """The offsets where f's normalised cumulative distribution reaches p in [0, 1]."""
    r = radius(f)
    return _bisect(lambda t: cumulative(f, t) / cumulative(f, r), p, -r, r)


@functools.lru_cache(maxsize=16)
def cells(f):
    """The kernel's map from v in [0, 1] to offsets in [-radius, 0] (kernels/filter.h): per cell of
    v, the cubic Hermite interpolation of the exact t(v) = F^-1(v^2 / 2) at the cell's ends, as
    power-basis coefficients (a, b, c, d) of s in [0, 1), the position in the cell."""
    count = layout.FILTER_CELLS
    v = np.arange(count + 1) / count
    t = inverse_cumulative(f, v * v / 2)
    t[0] = -radius(f)
    mass = float(cumulative(f, radius(f)))
    # dt/dv = v / f_normalised(t); at v = 0 its limit, 1 / sqrt(f_normalised'(-radius)).
    dt_dv = np.empty(count + 1)
    dt_dv[0] = 1.0 / math.sqrt(slope_at_radius(f) / mass)
    dt_dv[1:] = v[1:] / (evaluate(f, t[1:]) / mass)
    p0, p1, m0, m1 = t[:-1], t[1:], dt_dv[:-1] / count, dt_dv[1:] / count
    return np.stack([p0, m0, 3 * (p1 - p0) - 2 * m0 - m1, 2 * (p0 - p1) + m0 + m1], axis=1)


def _proposal_map(f, c):
    """The offset the kernel draws for c in [0, 1] and its derivative dt/dc (float64)."""
    c = np.asarray(c, dtype=float)
    upper = c > 0.5
    v = np.sqrt(2 * np.where(upper, 1 - c, c))
    cell = np.minimum((v * layout.FILTER_CELLS).astype(int), layout.FILTER_CELLS - 1)
    s = v * layout.FILTER_CELLS - cell
    a, b, cc, d = cells(f)[cell].T
    t = a + s * (b + s * (cc + s * d))
    with np.errstate(divide="ignore"):
        dt_dc = (b + s * (2 * cc + 3 * s * d)) * layout.FILTER_CELLS / v
    return np.where(upper, -t, t), dt_dc


def proposal_offset(f, c):
    """The kernel's sampled distribution's inverse cumulative distribution: the offset it draws
    for c in [0, 1]."""
    return _proposal_map(f, c)[0]


def proposal_cdf(f, t):
    """The kernel's sampled distribution's cumulative distribution at offsets t."""
    return _bisect(lambda c: proposal_offset(f, c), t, 0.0, 1.0)


def proposal_density(f, t):
    """The kernel's sampled density at offsets t."""
    return 1.0 / _proposal_map(f, proposal_cdf(f, t))[1]


@functools.lru_cache(maxsize=16)
def filter_record(f):
    """RenderParams.filter (layout.FILTER) for the filter `f` (cached: every launch's
    RenderParams holds it; not to be modified)."""
    record = np.zeros((), layout.FILTER)
    record["kind"][0] = layout.PIXEL_FILTERS[f.type]
    if f.type == "box":
        return record
    r = radius(f)
    record["support"] = (r, 1.0 / float(cumulative(f, r)), 0, 0)
    record["shape"] = (-0.5 / f.stddev**2, math.exp(-0.5 * (r / f.stddev) ** 2), 0, 0) if f.type == "gaussian" \
        else (1.0 / r, 0, 0, 0)
    record["cells"] = cells(f)
    # At -(k + 0.5), where a pixel k pixels from an edge meets it; 0 (no truncation) beyond the radius.
    edges = -(np.arange(layout.FILTER_EDGES) + 0.5)
    inside = edges > -r
    record["edge_cdf"].reshape(-1)[:] = np.where(inside, proposal_cdf(f, np.maximum(edges, -r)), 0.0)
    record["edge_mass"].reshape(-1)[:] = np.where(inside, cumulative(f, edges) / cumulative(f, r), 0.0)
    return record
