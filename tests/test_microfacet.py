"""The microfacet distributions behind the rough lobes (kernels/materials/microfacet.h, ggx.h,
beckmann.h), through kernels/tests.cl: normalisation, closed forms, the masking-shadowing terms
and the visible-normal samplers against their densities (chi-square: chi2 < dof + 5 sqrt(2 dof)).
"""
import numpy as np
import pyopencl as cl
import pytest
from scipy import special

from clrender import layout
from conftest import build_test_kernels
from test_dielectric import direction, float4, run, upload

DISTRIBUTIONS = layout.MICROFACET_DISTRIBUTIONS
MASKINGS = layout.MASKINGS


@pytest.fixture(scope="module")
def kernels(context):
    return build_test_kernels(context, DIELECTRIC=1)


def microfacet_values(queue, kernels, alpha, distribution, wo, h, wi=None, masking="separable"):
    """Per row: D(h), G1(wo), the visible-normal density of h from wo, G(wo, wi)."""
    wi = h if wi is None else wi
    context = queue.context
    (out,) = run(queue, cl.Kernel(kernels, "microfacet_values"), len(h), np.float32(alpha),
                 np.int32(DISTRIBUTIONS[distribution]), np.int32(MASKINGS[masking]),
                 upload(context, float4(wo)), upload(context, float4(h)), upload(context, float4(wi)),
                 outputs=[(len(h), 4)])
    return out.astype(float)


def sample_visible(queue, kernels, alpha, distribution, wo, u):
    """Visible normals h (n, 3) sampled with random numbers u (n, 2), and their densities."""
    context = queue.context
    wo = np.broadcast_to(wo, (len(u), 3))
    (out,) = run(queue, cl.Kernel(kernels, "sample_vndf_values"), len(u), np.float32(alpha),
                 np.int32(DISTRIBUTIONS[distribution]), upload(context, float4(wo)),
                 upload(context, np.ascontiguousarray(u, np.float32)), outputs=[(len(u), 4)])
    return out[:, :3].astype(float), out[:, 3].astype(float)


def hemisphere_cells(n_t, n_p, power):
    """Midpoints and solid angles of cells in (t, phi), cos(h) = 1 - t^power: dense near the
    normal, where narrow lobes live."""
    t = (np.arange(n_t) + 0.5) / n_t
    cos_h = 1 - t ** power
    d_cos = power * t ** (power - 1) / n_t
    phi = 2 * np.pi * (np.arange(n_p) + 0.5) / n_p
    cc, pp = np.meshgrid(cos_h, phi, indexing="ij")
    ss = np.sqrt(1 - cc ** 2)
    h = np.stack([ss * np.cos(pp), ss * np.sin(pp), cc], axis=-1).reshape(-1, 3)
    return h, np.repeat(d_cos, n_p) * 2 * np.pi / n_p


@pytest.mark.parametrize("distribution", list(DISTRIBUTIONS))
@pytest.mark.parametrize("alpha", [0.01, 0.1, 0.5, 1.0])
def test_distributions_are_normalised(queue, kernels, distribution, alpha):
    # The projected microfacet area is the macro area: integral of D(h) cos(h) = 1, and the
    # visible normals of any wo form a density: integral of D_wo(h) = 1 (Heitz 2018, eq. 2-3),
    # which holds only with the distribution's own G1. Midpoint quadrature.
    h, weight = hemisphere_cells(4000, 64, 4)
    for cos_o in (1.0, 0.5, 0.05):
        wo = np.broadcast_to(direction(cos_o, 0.7), h.shape)
        out = microfacet_values(queue, kernels, alpha, distribution, wo, h)
        assert np.sum(out[:, 0] * h[:, 2] * weight) == pytest.approx(1.0, abs=2e-3)
        assert np.sum(out[:, 2] * weight) == pytest.approx(1.0, abs=2e-3)


def beckmann_lambda(cos, alpha):
    """Walter et al. 2007, eq. 27, in float64."""
    a = cos / (alpha * np.sqrt(1 - cos ** 2))
    return (special.erf(a) - 1) / 2 + np.exp(-a * a) / (2 * a * np.sqrt(np.pi))


def test_beckmann_g1_across_the_range_of_its_lambda_polynomial(queue, kernels):
    # beckmann_lambda writes Lambda through a polynomial fitted on a = cot / alpha in (0, 3.5]
    # (beyond, Lambda < 1.5e-8 and G1 is 1): G1 there within 3e-7 of float64, about two float32
    # roundings of a value near 1 (the erfc form it replaced was within 1.1e-7). Dense in a, with
    # both ends and the cut-over at 3.5.
    alpha = 0.5
    a = np.concatenate([np.geomspace(1e-3, 3.5, 4000), [3.49999, 3.50001, 4.0]])
    cot = a * alpha
    cos = cot / np.sqrt(1 + cot ** 2)
    wo = np.array([direction(c, 0.0) for c in cos])
    g1 = microfacet_values(queue, kernels, alpha, "beckmann", wo, np.broadcast_to([0.0, 0.0, 1.0], wo.shape))[:, 1]
    exact = 1 / (1 + beckmann_lambda(cos, alpha))
    assert np.max(np.abs(g1 - exact)) < 3e-7


@pytest.mark.parametrize("alpha", [0.02, 0.3, 1.0])
def test_beckmann_matches_its_closed_forms(queue, kernels, alpha):
    # D, Smith's G1 and both masking-shadowing terms against float64 references written from
    # the angles (Walter et al. 2007, eqs. 25 and 27; Heitz 2014, eq. 99).
    rng = np.random.default_rng(4)
    cos_h = np.concatenate([[1.0], 1 - rng.uniform(0, 1, 500) ** 2 * min(1.0, 6 * alpha * alpha)])
    phi = rng.uniform(0, 2 * np.pi, cos_h.size)
    h = np.array([direction(c, p) for c, p in zip(cos_h, phi)])
    cos_o, cos_i = rng.uniform(0.02, 1, cos_h.size), rng.uniform(0.02, 1, cos_h.size)
    wo = np.array([direction(c, 0.3) for c in cos_o])
    wi = np.array([direction(c, 2.0) for c in cos_i])
    tan2 = (1 - cos_h ** 2) / cos_h ** 2
    d = np.exp(-tan2 / alpha ** 2) / (np.pi * alpha ** 2 * cos_h ** 4)
    lo, li = beckmann_lambda(cos_o, alpha), beckmann_lambda(cos_i, alpha)
    separable = microfacet_values(queue, kernels, alpha, "beckmann", wo, h, wi, "separable")
    correlated = microfacet_values(queue, kernels, alpha, "beckmann", wo, h, wi, "height_correlated")
    np.testing.assert_allclose(separable[:, 0], d, rtol=2e-5, atol=1e-30)
    np.testing.assert_allclose(separable[:, 1], 1 / (1 + lo), rtol=1e-5)
    np.testing.assert_allclose(separable[:, 3], 1 / ((1 + lo) * (1 + li)), rtol=2e-5)
    np.testing.assert_allclose(correlated[:, 3], 1 / (1 + lo + li), rtol=2e-5)
    # Normal incidence masks nothing, grazing incidence everything.
    ends = microfacet_values(queue, kernels, alpha, "beckmann", [direction(1.0), direction(0.0)], [direction(1.0)] * 2)
    assert ends[0, 1] == 1.0 and ends[1, 1] == 0.0


@pytest.mark.parametrize("distribution", list(DISTRIBUTIONS))
def test_separable_masking_is_the_product_of_g1(queue, kernels, distribution):
    # Mitsuba's G = G1(wo) G1(wi); the height-correlated G2 is never below it (Heitz 2014).
    rng = np.random.default_rng(6)
    cos_o, cos_i = rng.uniform(0.01, 1, 300), rng.uniform(-1, 1, 300)
    wo = np.array([direction(c) for c in cos_o])
    wi = np.array([direction(c, 1.0) if c >= 0 else -direction(-c, 1.0) for c in cos_i])
    h = np.broadcast_to(direction(1.0), wo.shape)
    g1_o = microfacet_values(queue, kernels, 0.4, distribution, wo, h)[:, 1]
    g1_i = microfacet_values(queue, kernels, 0.4, distribution, np.abs(wi), h)[:, 1]
    separable = microfacet_values(queue, kernels, 0.4, distribution, wo, h, wi, "separable")[:, 3]
    correlated = microfacet_values(queue, kernels, 0.4, distribution, wo, h, wi, "height_correlated")[:, 3]
    np.testing.assert_allclose(separable, g1_o * g1_i, rtol=1e-6)
    assert np.all(correlated >= separable * (1 - 1e-6))
    assert np.all(correlated <= np.minimum(g1_o, g1_i) * (1 + 1e-6))


T_BINS, PHI_BINS, SUB = 24, 24, 8


def lobe_cos(t, alpha):
    """cos(h) at t in [0, 1], t = s / (1 + s) for tan(h) = alpha s: bins of t cover any lobe
    of width alpha, its tail included, evenly."""
    with np.errstate(divide="ignore"):
        return np.where(t < 1, (1 - t) / np.hypot(1 - t, alpha * t), 0.0)


def lobe_cells(alpha):
    """Midpoint directions and solid angles of SUB x SUB cells per (t, phi) bin."""
    edges = np.linspace(0, 1, T_BINS * SUB + 1)
    cos_edges = lobe_cos(edges, alpha)
    cos_mid = lobe_cos((edges[:-1] + edges[1:]) / 2, alpha)
    phi = 2 * np.pi * (np.arange(PHI_BINS * SUB) + 0.5) / (PHI_BINS * SUB)
    cc, pp = np.meshgrid(cos_mid, phi, indexing="ij")
    ss = np.sqrt(1 - cc ** 2)
    h = np.stack([ss * np.cos(pp), ss * np.sin(pp), cc], axis=-1).reshape(-1, 3)
    solid_angle = np.repeat(cos_edges[:-1] - cos_edges[1:], PHI_BINS * SUB) * 2 * np.pi / (PHI_BINS * SUB)
    return h, solid_angle


@pytest.mark.parametrize("distribution", list(DISTRIBUTIONS))
@pytest.mark.parametrize("alpha,cos_o", [(0.05, 0.9), (0.3, 1.0), (0.3, 0.5), (0.6, 0.1), (1.0, 0.02)])
def test_visible_normals_follow_their_density(queue, kernels, distribution, alpha, cos_o):
    # Chi-square of sample_microfacet_visible against sample_microfacet_visible_pdf integrated
    # over bins of (t, phi) (lobe_cos). Uniform random numbers from numpy, plus the corners of
    # the unit square (every h finite and unit).
    count = 200_000
    rng = np.random.default_rng(11)
    u = np.concatenate([rng.uniform(0, 1, (count, 2)), [[0, 0], [0, 1], [1, 0], [1, 1], [1e-9, 0.5]]])
    wo = direction(cos_o, 0.4)
    h, pdf = sample_visible(queue, kernels, alpha, distribution, wo, u)
    assert np.all(np.isfinite(h)) and np.all(np.isfinite(pdf))
    np.testing.assert_allclose(np.linalg.norm(h, axis=1), 1.0, atol=1e-5)
    h, pdf = h[:count], pdf[:count]
    assert np.all(h @ wo > -1e-6) and np.all(pdf > 0)
    cells, solid_angle = lobe_cells(alpha)
    density = microfacet_values(queue, kernels, alpha, distribution, np.broadcast_to(wo, cells.shape), cells)[:, 2]
    p_bin = (density * solid_angle).reshape(T_BINS, SUB, PHI_BINS, SUB).sum(axis=(1, 3)).ravel()
    assert p_bin.sum() == pytest.approx(1.0, abs=2e-3)
    tan_h = np.sqrt(np.clip(1 - h[:, 2] ** 2, 0, None)) / h[:, 2]
    t = tan_h / alpha / (1 + tan_h / alpha)
    ti = np.minimum((t * T_BINS).astype(int), T_BINS - 1)
    pi = np.minimum((np.mod(np.arctan2(h[:, 1], h[:, 0]), 2 * np.pi) / (2 * np.pi) * PHI_BINS).astype(int),
                    PHI_BINS - 1)
    observed = np.bincount(ti * PHI_BINS + pi, minlength=p_bin.size)
    expected = p_bin * count
    big = expected > 20
    chi2 = np.sum((observed[big] - expected[big]) ** 2 / expected[big])
    dof = big.sum() - 1
    assert chi2 < dof + 5 * np.sqrt(2 * dof), (chi2, dof)
    # Each sample's density is the density function's at its normal.
    check = microfacet_values(queue, kernels, alpha, distribution, np.broadcast_to(wo, h[:2000].shape), h[:2000])[:, 2]
    np.testing.assert_allclose(pdf[:2000], check, rtol=1e-5)


def beckmann_first_slope(tan_theta, u):
    """The first slope of Beckmann's visible normals, in float64: the root s of
    erf(s) + tan / sqrt(pi) exp(-s^2) = 2 u - 1 where cot >= 4 (Jakob 2014), by Newton's method."""
    x0 = 2 * u - 1
    s = special.erfinv(x0)
    for _ in range(50):
        value = special.erf(s) - x0 + tan_theta / np.sqrt(np.pi) * np.exp(-s * s)
        s = s - value / (2 / np.sqrt(np.pi) * np.exp(-s * s) * (1 - s * tan_theta))
    return s


def test_beckmann_slopes_near_normal_incidence_are_the_root(queue, kernels):
    # Below BECKMANN_NEAR_NORMAL_TAN (0.05) the kernel sums a series instead of taking Newton
    # steps: its slopes are the float64 root to the float32 rounding of the slope itself and of
    # the kernel's inverse_erf, whose error the slopes at normal incidence (tan 0) show.
    u = np.concatenate([np.linspace(1e-6, 1 - 1e-6, 2001), [2e-6, 1e-5, 1 - 1e-5]])
    tans = np.array([0.0, 0.01, 0.02, 0.035, 0.0499])
    tan_theta = np.repeat(tans, len(u))
    cos_theta = (1 / np.sqrt(1 + tan_theta ** 2)).astype(np.float32)
    tan32 = np.sqrt(1 - cos_theta.astype(float) ** 2) / cos_theta   # what the kernel sees
    uu = np.tile(u, len(tans))
    u2 = np.ascontiguousarray(np.stack([uu, np.full_like(uu, 0.5)], axis=1), np.float32)
    (out,) = run(queue, cl.Kernel(kernels, "beckmann_visible_slopes"), len(uu), upload(queue.context, cos_theta),
                 upload(queue.context, u2), outputs=[(len(uu), 2)])
    error = np.abs(out[:, 0] - beckmann_first_slope(tan32, uu.astype(np.float32).astype(float))).reshape(len(tans), -1)
    erfinv_error = error[0]
    assert np.all(error[1:] <= erfinv_error + 4 * np.spacing(np.float32(np.abs(out[:, 0]).max()))), error.max(axis=1)
