"""The samplers of camera paths (kernels/rng.h, render.sampler).

sobol: bit-exact against Burley's construction with Sobol's generator matrices (the kernel uses
shortcuts), every 2D draw of one pixel's first 2^k samples stratified as a (0,2)-sequence,
values in [0, 1), draws of different dimensions and pixels independent (chi-square with its
mean + 5 sd bound), the points of different dimensions paired at random, each sample uniform
on its own, and a path vertex's three draws at once (draw_vertex_numbers) those one at a time.
Splitting invariance is covered by test_determinism.py (default sampler).
"""
import numpy as np
import pyopencl as cl
import pytest

from clrender import layout
from conftest import build_test_kernels

M32 = 0xFFFFFFFF
LOG2_SAMPLES = 8


def reverse_bits(x):
    return int(f"{x:032b}"[::-1], 2)


def laine_karras(x, seed):
    x ^= (x * 0x3D20ADEA) & M32
    x = (x + seed) & M32
    x = (x * ((seed >> 16) | 1)) & M32
    x ^= (x * 0x05526C56) & M32
    x ^= (x * 0x53A22864) & M32
    return x


def owen(x, seed):
    return reverse_bits(laine_karras(reverse_bits(x), seed))


def sobol(index, dimension):
    """Sobol dimension 0 (identity matrix) or 1 (x + 1: v_{k+1} = v_k ^ v_k >> 1)."""
    v, x = 1 << 31, 0
    for bit in range(32):
        if index >> bit & 1:
            x ^= v if dimension == 1 else 1 << (31 - bit)
        v ^= v >> 1
    return x


def test_owen_scrambled_sobol_matches_the_generator_matrices(context, queue):
    rng = np.random.default_rng(3)
    index = rng.integers(0, 2**32, 2048, dtype=np.uint64).astype(np.uint32)
    index[:64] = np.arange(64)
    seed = rng.integers(0, 2**32, 2048, dtype=np.uint64).astype(np.uint32)
    out = np.empty((2048, 4), np.uint32)
    mf = cl.mem_flags
    buffers = [cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (index, seed)]
    out_buffer = cl.Buffer(context, mf.WRITE_ONLY, out.nbytes)
    cl.Kernel(build_test_kernels(context), "owen_sobol_bits")(queue, (2048,), None, *buffers, out_buffer)
    cl.enqueue_copy(queue, out, out_buffer)
    expected = [(owen(sobol(i, 0), s), owen(sobol(i, 1), s), owen(i, s), reverse_bits(i))
                for i, s in zip(index.tolist(), seed.tolist())]
    assert out.tolist() == [list(e) for e in expected]


def path_samples(context, queue, sampler, pixels, samples, dims, seed=11):
    out = np.empty((pixels, samples, dims, 4), np.float32)
    buffer = cl.Buffer(context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    cl.Kernel(build_test_kernels(context), "path_samples")(
        queue, (samples, pixels), None, np.int32(layout.SAMPLERS[sampler]), np.uint32(seed),
        np.int32(samples), np.int32(dims), buffer)
    cl.enqueue_copy(queue, out, buffer)
    return out[..., :3].astype(float)


@pytest.mark.parametrize("sampler", ["sobol", "independent"])
def test_a_vertex_draws_the_next_three_dimensions(context, queue, sampler):
    """draw_vertex_numbers (path.h's and the packets' numbers of a vertex) gives, bit for bit,
    the three 2D draws one at a time would, and moves the counter as far."""
    pixels, samples = 16, 64
    out = np.empty((pixels, samples, 8, 2), np.float32)
    buffer = cl.Buffer(context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    cl.Kernel(build_test_kernels(context), "vertex_numbers")(
        queue, (samples, pixels), None, np.int32(layout.SAMPLERS[sampler]), np.uint32(5), np.int32(samples), buffer)
    cl.enqueue_copy(queue, out, buffer)
    together, apart, counters = out[:, :, 0:3], out[:, :, 3:6], out[:, :, 6]
    assert np.array_equal(together.view(np.uint32), apart.view(np.uint32))
    assert np.all(counters[..., 0] == counters[..., 1]) and counters[0, 0, 0] == (4 if sampler == "sobol" else 8)
    assert len(np.unique(together.reshape(-1))) > 0.99 * together.size   # six distinct numbers a vertex


@pytest.fixture(scope="module")
def sobol_points(context, queue):
    return path_samples(context, queue, "sobol", 64, 2**LOG2_SAMPLES, 6)


def test_values_lie_in_the_unit_interval(sobol_points):
    assert np.all((sobol_points >= 0) & (sobol_points < 1))


def cell_counts(x, y, log2_x, log2_y):
    """Points per elementary interval of 2^-log2_x by 2^-log2_y."""
    i = np.floor(x * 2**log2_x).astype(int)
    j = np.floor(y * 2**log2_y).astype(int)
    return np.bincount(i * 2**log2_y + j, minlength=2 ** (log2_x + log2_y))


def test_every_pair_is_a_02_sequence_in_each_pixel(sobol_points):
    """The first 2^k samples put one point in every elementary interval of area 2^-k, for each
    prefix length k, pixel and dimension; the 1D draws one in every interval of length 2^-k."""
    pixels, _, dims, _ = sobol_points.shape
    for k in (2, 5, LOG2_SAMPLES):
        for pixel in range(pixels):
            for d in range(dims):
                x, y, single = sobol_points[pixel, :2**k, d].T
                for a in range(k + 1):
                    assert np.all(cell_counts(x, y, a, k - a) == 1), (k, pixel, d, a)
                assert np.all(cell_counts(single, np.zeros_like(single), k, 0) == 1), (k, pixel, d)


def test_independent_samples_are_not_stratified(context, queue):
    """The stratification test can fail: hashed i.i.d. numbers leave cells empty."""
    x, y, _ = path_samples(context, queue, "independent", 1, 2**LOG2_SAMPLES, 1)[0, :, 0].T
    assert np.any(cell_counts(x, y, 4, 4) != 1)


def chi_square_2d(x, y):
    """Chi-square of 8 x 8 equal cells and its bound (mean + 5 sd)."""
    observed = cell_counts(x, y, 3, 3)
    expected = x.size / 64
    dof = 63
    return np.sum((observed - expected) ** 2 / expected), dof + 5 * np.sqrt(2 * dof)


def test_dimensions_and_pixels_are_independent(context, queue):
    """Joint histograms of one sample's draws in two dimensions, and of two neighbouring pixels'
    draws of one sample, over many pixels (independent across pixels) are uniform."""
    points = path_samples(context, queue, "sobol", 4096, 16, 4)
    pairs = [(points[:, :, 0, 0], points[:, :, 1, 0]),     # dimension 0 against 1, same sample
             (points[:, :, 0, 1], points[:, :, 3, 1]),
             (points[:, :, 1, 2], points[:, :, 2, 2]),     # the 1D draws
             (points[:-1, :, 0, 0], points[1:, :, 0, 0])]  # neighbouring pixels, same sample
    for x, y in pairs:
        statistic, bound = chi_square_2d(x.ravel(), y.ravel())
        assert statistic < bound
    means = points.reshape(-1, 4, 3).mean(axis=0)
    # Standard error of i.i.d. uniforms (stratification only lowers it).
    assert np.all(np.abs(means - 0.5) < 5 * np.sqrt(1 / 12 / (4096 * 16)))


def test_dimensions_pair_their_points_at_random(context, queue):
    """Which of a pixel's points one dimension gives a sample does not tell which another gives
    it: the count of a pixel's 64 samples whose first coordinate lies below 1/2 in both of two
    dimensions varies over pixels as with each octave [2^j, 2^(j+1)) of the sample index
    permuted at random (rng.h, sobol_shuffled_index): hypergeometric per octave, 4.54 in all.
    Bound: 5 standard errors of a variance over 4096 pixels. A nested uniform scramble of the
    index, which keeps the pairs {2m, 2m + 1} together in every dimension, gives about 8 and
    raised the teapot's variance by a third; a permutation that hardly moves the index's lowest
    bit, 10."""
    points = path_samples(context, queue, "sobol", 4096, 64, 3)
    expected = 0.25 + sum(n * n / (16 * (n - 1)) for n in (2, 4, 8, 16, 32))
    tolerance = 5 * expected * np.sqrt(2 / (4096 - 1))
    for (a, u), (b, v) in (((0, 0), (1, 0)), ((0, 1), (2, 0)), ((1, 0), (2, 2))):   # pairs' x, y; singles
        both_low = np.sum((points[:, :, a, u] < 0.5) & (points[:, :, b, v] < 0.5), axis=1)
        assert abs(both_low.mean() - 16) < 5 * np.sqrt(expected / 4096)
        assert abs(both_low.var(ddof=1) - expected) < tolerance, (a, u, b, v, both_low.var(ddof=1), expected)


def test_each_sample_is_uniform_over_the_square(context, queue):
    """Sample i of a pixel, for each small i alone, lies anywhere in the unit square with equal
    probability (over pixels), in every dimension: what makes a render of few samples unbiased.
    Chi-square of 8 x 8 cells over 4096 pixels. Scramble seeds of a dimension's two coordinates
    that share their lowest bits flip both first digits alike: sample 0 then keeps to two of the
    four quadrants."""
    points = path_samples(context, queue, "sobol", 4096, 4, 3)
    for i in range(4):
        for d in range(3):
            statistic, bound = chi_square_2d(points[:, i, d, 0], points[:, i, d, 1])
            assert statistic < bound, (i, d, statistic)
