"""Chi-square tests of the device's direction sampling routines against their pdfs.

Bins are equal-probability under the claimed density (20 in cos(theta) x 8 in phi), so every
bin expects count / 160 samples; the statistic must stay below dof + 5 sqrt(2 dof) (its mean plus
five standard deviations). Each returned pdf must also equal the analytic density.
"""
import numpy as np
import pyopencl as cl
import pytest

from conftest import build_test_kernels

COUNT = 160_000
COS_BINS, PHI_BINS = 20, 8


def sample(context, queue, routine, g=0.0, seed=7):
    out = np.empty((COUNT, 4), np.float32)
    buffer = cl.Buffer(context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    kernel = cl.Kernel(build_test_kernels(context), "sample_directions")
    kernel(queue, (COUNT,), None, np.int32(routine), np.float32(g), np.uint32(seed), buffer)
    cl.enqueue_copy(queue, out, buffer)
    return out[:, :3].astype(float), out[:, 3].astype(float)


def cos_theta(d):
    """cos(theta) from a unit direction, exact to float64 near the poles: 1 -/+ (x^2 + y^2) / (1 +/- z)
    keeps the precision that float32 z has lost (lobes of |g| -> 1 live within 1e-6 of a pole)."""
    r2 = d[:, 0] ** 2 + d[:, 1] ** 2
    z = np.clip(d[:, 2], -1, 1)
    return np.where(z >= 0, 1 - r2 / (1 + np.abs(z)), r2 / (1 + np.abs(z)) - 1)


def hg_pdf(mu, g):
    return (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * mu) ** 1.5)


def hg_cos_quantiles(g, probabilities):
    """Inverse of the HG CDF in mu = cos(theta) (closed form)."""
    if g == 0:
        return 2 * probabilities - 1
    s = (1 - g * g) / (1 - g + 2 * g * probabilities)
    return np.clip((1 + g * g - s * s) / (2 * g), -1, 1)


def chi_square(directions, cos_edges):
    mu = cos_theta(directions)
    phi = np.arctan2(directions[:, 1], directions[:, 0]) % (2 * np.pi)
    i = np.clip(np.searchsorted(cos_edges, mu, side="right") - 1, 0, COS_BINS - 1)
    j = np.minimum((phi / (2 * np.pi) * PHI_BINS).astype(int), PHI_BINS - 1)
    observed = np.bincount(i * PHI_BINS + j, minlength=COS_BINS * PHI_BINS)
    expected = COUNT / (COS_BINS * PHI_BINS)
    statistic = np.sum((observed - expected) ** 2 / expected)
    dof = COS_BINS * PHI_BINS - 1
    return statistic, dof + 5 * np.sqrt(2 * dof)


def test_cosine_hemisphere(context, queue):
    d, pdf = sample(context, queue, 0)
    assert np.all(d[:, 2] >= 0)
    edges = np.sqrt(np.linspace(0, 1, COS_BINS + 1))  # P(mu <= x) = x^2
    statistic, bound = chi_square(d, edges)
    assert statistic < bound
    np.testing.assert_allclose(pdf, d[:, 2] / np.pi, rtol=1e-4, atol=1e-7)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1, rtol=1e-5)


def test_uniform_sphere(context, queue):
    d, pdf = sample(context, queue, 1)
    statistic, bound = chi_square(d, np.linspace(-1, 1, COS_BINS + 1))
    assert statistic < bound
    np.testing.assert_allclose(pdf, 1 / (4 * np.pi), rtol=1e-6)


@pytest.mark.parametrize("g", [0.99999999, -0.99999999])
def test_henyey_greenstein_with_g_rounding_to_one(context, queue, g):
    # g is valid (|g| < 1) but rounds to +-1 in float32, where the density is 0 / 0 at the peak:
    # the kernel uses the largest float32 g below 1 instead, a lobe within 1e-7 rad of the axis.
    assert abs(np.float32(g)) == 1.0
    d, pdf = sample(context, queue, 2, g)
    assert np.all(np.isfinite(d)) and np.all(np.isfinite(pdf)) and np.all(pdf > 0)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1, rtol=1e-5)
    assert np.mean(np.sign(g) * d[:, 2] > 1 - 1e-6) > 0.99


@pytest.mark.parametrize("g", [-0.9, -0.3, 0.0, 0.5, 0.9, 0.999])
def test_henyey_greenstein(context, queue, g):
    d, pdf = sample(context, queue, 2, g)
    edges = hg_cos_quantiles(g, np.linspace(0, 1, COS_BINS + 1))
    edges[0], edges[-1] = -1.0, 1.0
    statistic, bound = chi_square(d, edges)
    assert statistic < bound, (statistic, bound)
    assert np.all(np.isfinite(pdf)) and np.all(pdf > 0)
    np.testing.assert_allclose(pdf, hg_pdf(cos_theta(d), g), rtol=2e-3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1, rtol=1e-5)
