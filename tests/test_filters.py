"""Pixel reconstruction filters: the kernel's offsets (kernels/filter.h) against the filters
(clrender/filters.py), for pixels inside the image and at its edges, where the filter is
truncated to the image.

Offsets are drawn from the tabulated density q and weighted by f / q, so three checks: the
offsets follow q (chi-square over COUNT samples in BINS bins of equal probability under q; the
statistic must stay below dof + 5 sqrt(2 dof)), each weight is f / q normalised, and the
weighted offsets follow f (in BINS bins of equal filter mass, the mean weight in each bin is
1 / BINS to within 5 standard errors of its mean). Fixed seeds.
"""
import math

import numpy as np
import pyopencl as cl
import pytest
from scipy.integrate import quad

from clrender import filters, layout, splatting
from clrender.scene import Filter
from conftest import build_test_kernels, z_bound

COUNT, BINS = 200_000, 40
FILTERS = [Filter("gaussian", stddev=0.5), Filter("gaussian", stddev=1.3), Filter("tent", radius=1.0),
           Filter("tent", radius=2.5)]
# (pixel, pixels along the axis): inside, at both edges, next to one, and an image one pixel wide.
PIXELS = [(20, 64), (0, 64), (1, 64), (63, 64), (0, 1)]


def device_samples(context, queue, f, pixel, size, seed=3):
    """(offsets, weights) of COUNT samples of `pixel`."""
    record = filters.filter_record(f)
    out = np.empty((COUNT, 2), np.float32)
    mf = cl.mem_flags
    out_buffer = cl.Buffer(context, mf.WRITE_ONLY, out.nbytes)
    filter_buffer = cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=record.tobytes())
    cl.Kernel(build_test_kernels(context), "filter_samples")(queue, (COUNT,), None, filter_buffer, np.int32(pixel),
                                               np.int32(size), np.uint32(seed), out_buffer)
    cl.enqueue_copy(queue, out, out_buffer)
    return out[:, 0].astype(float), out[:, 1].astype(float)


def support(f, pixel, size):
    """The offsets the image leaves to `pixel`: the filter's support, cut at the image's edges."""
    r = filters.radius(f)
    return max(-r, -(pixel + 0.5)), min(r, size - pixel - 0.5)


def filter_mass(f, low, high):
    return float(filters.cumulative(f, high) - filters.cumulative(f, low))


ids = [f"{f.type}-{f.stddev if f.type == 'gaussian' else f.radius}" for f in FILTERS]


@pytest.mark.parametrize("f", FILTERS, ids=ids)
@pytest.mark.parametrize("pixel,size", PIXELS)
def test_offsets_follow_the_tabulated_density(context, queue, f, pixel, size):
    t, _ = device_samples(context, queue, f, pixel, size)
    low, high = support(f, pixel, size)
    assert t.min() >= low - 1e-6 and t.max() <= high + 1e-6
    probabilities = filters.proposal_cdf(f, np.array([low, high]))
    edges = filters.proposal_offset(f, np.linspace(*probabilities, BINS + 1))
    observed = np.bincount(np.clip(np.searchsorted(edges, t, side="right") - 1, 0, BINS - 1), minlength=BINS)
    expected = COUNT / BINS
    dof = BINS - 1
    assert np.sum((observed - expected) ** 2 / expected) < dof + 5 * np.sqrt(2 * dof)


@pytest.mark.parametrize("f", FILTERS, ids=ids)
@pytest.mark.parametrize("pixel,size", PIXELS)
def test_weights_are_the_filter_over_the_tabulated_density(context, queue, f, pixel, size):
    t, weight = device_samples(context, queue, f, pixel, size)
    low, high = support(f, pixel, size)
    probability = float(filters.proposal_cdf(f, high) - filters.proposal_cdf(f, low))
    expected = filters.evaluate(f, t) / filter_mass(f, low, high) / (filters.proposal_density(f, t) / probability)
    # float32: the offset is within a few ulp of its float64 value, and f and q change by
    # |f'| and |q'| over that, tiny against both but near the radius, where both are near 0.
    assert np.allclose(weight, expected, rtol=2e-5, atol=2e-5)
    # q is so close to f that the weights hardly vary (their variance under q is 2.3e-8 for
    # Mitsuba's gaussian at 64 cells): regions of one colour stay noiseless. A tent is its own
    # q: its weights are 1 but for rounding.
    assert np.var(weight) < (1e-7 if f.type == "gaussian" else 1e-12)


@pytest.mark.parametrize("f", FILTERS, ids=ids)
@pytest.mark.parametrize("pixel,size", PIXELS)
def test_weighted_offsets_follow_the_filter(context, queue, f, pixel, size):
    t, weight = device_samples(context, queue, f, pixel, size, seed=11)
    low, high = support(f, pixel, size)
    mass = filters.cumulative(f, np.array([low, high])) / filters.cumulative(f, filters.radius(f))
    edges = filters.inverse_cumulative(f, np.linspace(*mass, BINS + 1))
    index = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, BINS - 1)
    for b in range(BINS):
        assert z_bound(np.where(index == b, weight, 0.0), 1.0 / BINS) < 5, b


@pytest.mark.parametrize("f", FILTERS, ids=ids)
def test_cumulative_is_the_integral_of_the_filter(f):
    r = filters.radius(f)
    for t in (-r, -0.7 * r, -0.5, 0.0, 0.3, 0.9 * r, r):
        integral = quad(lambda x: float(filters.evaluate(f, x)), -r, t, points=[0.0] if -r < 0 < t else None)[0]
        assert math.isclose(float(filters.cumulative(f, t)), integral, rel_tol=1e-9, abs_tol=1e-12)


def test_the_box_is_identity_and_needs_no_tables():
    record = filters.filter_record(Filter("box"))
    assert record["kind"][0] == layout.PIXEL_FILTERS["box"]
    assert not np.any(record["cells"])


@pytest.mark.parametrize("f", [f for f in FILTERS if f.type != "box"], ids=lambda f: f"{f.type}-{f.stddev if f.type == 'gaussian' else f.radius}")
@pytest.mark.parametrize("position", [0.0, 0.37, 0.999])
def test_a_row_of_filter_values_is_the_filter(context, queue, f, position):
    # A splat record's weights (kernels/splat.h): the filter at the offsets from the centres of
    # the pixels -reach .. reach away to a sample at `position` in its pixel, and two beyond
    # (0), from the gaussian's recurrence: within 2e-6 of float64 (exp_fast: 2e-7 relative per
    # exp, a few products per value).
    reach = splatting.reach(f)
    t = -reach - 1 + 0.5 - position
    out = np.empty(2 * reach + 3, np.float32)
    out_buffer = cl.Buffer(context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    filter_buffer = cl.Buffer(context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                              hostbuf=filters.filter_record(f).tobytes())
    cl.Kernel(build_test_kernels(context), "filter_row_values")(queue, out.shape, None, filter_buffer,
                                                                  np.float32(t), out_buffer)
    cl.enqueue_copy(queue, out, out_buffer)
    expected = filters.evaluate(f, np.float32(t) + np.arange(len(out)))
    np.testing.assert_allclose(out, expected, rtol=0, atol=2e-6)
    assert out[0] == 0.0 and out[-1] == 0.0
