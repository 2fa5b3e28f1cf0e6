"""Splatting (render.filter_method "splat", kernels/splat.h, clrender/splatting.py): each sample
counts in every pixel its filter reaches, and a pixel is the weighted mean of those samples.

The image of an emitting quadrant against black has a closed form under both filter methods:
a pixel's expectation is the filter's mass over the emitting part of the image over its mass
over the whole image (the filter truncated at the image's edges), separable in x and y. The
renders' per-pixel means over SEEDS seeds are held to it within Z standard errors of that mean
(Student's t with SEEDS - 1 degrees of freedom: a chance below 1e-4 per pixel, for the few
dozen pixels where an edge makes the value uncertain and at least 10 samples are expected on
either side); splatted pixels beyond the filter's reach of the edges are exactly 1 or 0. Splatted sums must not depend on how the
samples are split into passes or the image into strips, and splatting must lower the noise of
each pixel, as its reason to exist claims."""
from dataclasses import replace

import numpy as np
import pytest

import clrender
from clrender import filters
from clrender.distributed import merge_strips
from clrender.render import Accumulation, image_result
from clrender.scene import Filter
from conftest import TEST_DEVICE

WIDTH, HEIGHT = 24, 16
# The emitter's right and lower edges cross pixels, so that a pixel's radiance depends on where
# in it a sample falls (a filter weighing samples at mirrored positions would show).
EDGE_COLUMN, EDGE_ROW = 10.3, 5.6
SEEDS, SPP, Z = 16, 64, 5.5
FILTERS = [Filter("gaussian", stddev=0.5), Filter("tent", radius=2.5), Filter("tent", radius=1.0)]


def filter_dict(f):
    return {"type": f.type, **({"stddev": f.stddev} if f.type == "gaussian" else {"radius": f.radius})}


def quadrant_scene(f, method, sampler="independent"):
    """A pinhole camera at the origin looking down -z at an emitting rectangle (radiance 1) whose
    right and lower edges project exactly onto the image positions EDGE_COLUMN and EDGE_ROW."""
    tan_half = np.tan(np.radians(40.0) / 2)
    x_edge = (2 * EDGE_COLUMN / WIDTH - 1) * tan_half * WIDTH / HEIGHT
    y_edge = (1 - 2 * EDGE_ROW / HEIGHT) * tan_half
    return {
        "camera": {"position": [0, 0, 0], "look_at": [0, 0, -1], "up": [0, 1, 0], "fov": 40.0,
                   "resolution": [WIDTH, HEIGHT], "filter": filter_dict(f)},
        "render": {"max_depth": 2, "sampler": sampler, "filter_method": method},
        "materials": [{"name": "light", "type": "emissive", "radiance": [1, 1, 1]}],
        "shapes": [{"type": "rectangle", "material": "light",
                    "transform": {"scale": [50, 50, 1], "translate": [x_edge - 50, y_edge + 50, -1]}}],
    }


def truncated_mass_fraction(f, pixels, edge, size):
    """The filter's mass over [0, edge) over its mass over [0, size), seen from each pixel's centre."""
    centre = np.asarray(pixels, float) + 0.5
    return ((filters.cumulative(f, centre) - filters.cumulative(f, centre - edge))
            / (filters.cumulative(f, centre) - filters.cumulative(f, centre - size)))


def expected_image(f):
    return np.outer(truncated_mass_fraction(f, np.arange(HEIGHT), EDGE_ROW, HEIGHT),
                    truncated_mass_fraction(f, np.arange(WIDTH), EDGE_COLUMN, WIDTH))


def t_statistic(renders, expected):
    """Per pixel, |mean - expected| over the standard error of the mean; 0 where the expected
    value is so near 0 or 1 that the rarer outcome has fewer than 10 expected samples in SEEDS x
    SPP (the mean is then far from normal: its standard error is no measure of it)."""
    mean, error = renders.mean(axis=0), renders.std(axis=0, ddof=1) / np.sqrt(len(renders))
    testable = expected * (1 - expected) * renders.shape[0] * SPP >= 10
    with np.errstate(divide="ignore", invalid="ignore"):
        statistic = np.where(error > 0, np.abs(mean - expected) / error, np.where(mean == expected, 0.0, np.inf))
    return np.where(testable, statistic, 0.0)


@pytest.mark.parametrize("method", ["splat", "importance"])
@pytest.mark.parametrize("f", FILTERS, ids=lambda f: f"{f.type}-{f.stddev if f.type == 'gaussian' else f.radius}")
def test_an_emitting_quadrant_has_the_truncated_filters_image(f, method):
    renderer = clrender.Renderer(quadrant_scene(f, method), TEST_DEVICE)
    renders = np.stack([renderer.render(spp=SPP, seed=seed).image[..., 0] for seed in range(SEEDS)]).astype(float)
    expected = expected_image(f)
    statistic = t_statistic(renders, expected)
    worst = np.unravel_index(np.argmax(statistic), statistic.shape)
    assert statistic.max() < Z, (f"pixel {worst[::-1]}: {renders.mean(axis=0)[worst]:.4f} against "
                                 f"{expected[worst]:.4f}")
    # Where the filter does not reach the edges every sample a pixel sees is the same: splatting
    # gives it exactly.
    if method == "splat":
        assert np.all(renders[:, expected == 1.0] == 1.0) and np.all(renders[:, expected == 0.0] == 0.0)
        assert np.sum(expected == 1.0) > 0 and np.sum(expected == 0.0) > 0


def splatted_cornell_box(resolution=(20, 14)):
    scene = clrender.load_scene("scenes/cornell_box.json")
    camera = replace(scene.camera, resolution=resolution, filter=Filter("gaussian", stddev=0.5))
    return replace(scene, camera=camera, render=replace(scene.render, filter_method="splat", max_depth=4))


def test_splatted_sums_do_not_depend_on_passes_or_strips():
    scene = splatted_cornell_box()
    renderer = clrender.Renderer(scene, TEST_DEVICE)
    expected = renderer.render(spp=7, seed=3, aovs=["albedo", "variance"])
    split = renderer.render(spp=7, seed=3, samples_per_pass=2, aovs=["albedo", "variance"])
    assert np.array_equal(split.image, expected.image)
    width, height = scene.camera.resolution
    # Strips of 3 rows (the filter reaches 2), in chunks of 4 and 3 samples.
    states = []
    for top in range(0, height, 3):
        state = Accumulation.start((0, top, width, min(3, height - top)), sample_aovs=True)
        for samples in (4, 3):
            state = renderer.accumulate(state, samples, seed=3)
        states.append(state)
    merged = image_result(scene, merge_strips(scene, states), ["albedo", "variance"])
    assert np.array_equal(merged.image, expected.image)
    assert merged.samples == expected.samples == 7
    for name in ("albedo", "variance"):
        assert np.array_equal(merged.aovs[name], expected.aovs[name]), name
    for name in ("depth", "normal", "object_id"):
        assert np.array_equal(merged.aux[name], expected.aux[name]), name


def test_splatting_lowers_the_noise_of_each_pixel():
    """On white noise a gaussian of stddev 0.5 leaves 1 / (4 pi stddev^2) = 0.32 of the variance
    of drawing each sample's position from its own pixel's filter; the Cornell box's noise is
    nearly white at 1 spp. The mean per-pixel variance over SEEDS renders must fall below half of
    filter importance sampling's: the variance estimates' relative standard error over 280
    pixels x 15 degrees of freedom is about 2 %, so half is 20 of them away from both."""
    variances = {}
    for method in ("splat", "importance"):
        scene = splatted_cornell_box()
        scene = replace(scene, render=replace(scene.render, filter_method=method, sampler="independent"))
        renderer = clrender.Renderer(scene, TEST_DEVICE)
        renders = np.stack([renderer.render(spp=1, seed=seed).image for seed in range(SEEDS)]).astype(float)
        variances[method] = renders.var(axis=0, ddof=1)[2:-2, 2:-2].mean()
    assert variances["splat"] < 0.5 * variances["importance"], variances


def reference_gather(records, traced, target, reach, start):
    """What the gather adds to `start` (target's pixels x 4): for each pixel, the records of the
    traced pixels within `reach`, weighted by the x weight of the column offset times the y
    weight of the row offset (kernels/splat.h), in float64."""
    x0, y0, width, height = traced
    planes = records.reshape(len(records), -1, height, width).astype(float)
    sums = start.reshape(target[3], target[2], 4).astype(float).copy()
    for ty in range(target[3]):
        for tx in range(target[2]):
            x, y = target[0] + tx, target[1] + ty
            for qy in range(max(y - reach, y0), min(y + reach, y0 + height - 1) + 1):
                for qx in range(max(x - reach, x0), min(x + reach, x0 + width - 1) + 1):
                    record = planes[:, :, qy - y0, qx - x0]
                    w = record[:, 3 + reach + (x - qx)] * record[:, 3 + 3 * reach + 1 + (y - qy)]
                    sums[ty, tx, :3] += (record[:, :3] * w[:, None]).sum(axis=0)
                    sums[ty, tx, 3] += w.sum()
    return sums.reshape(-1, 4)


# Target tiles in the traced pixels (5..24) x (2..8) of a 40 x 12 image, neither a multiple of
# the 8 lanes wide: one touching their right edge, one their left and top edges (where the
# neighbours of a packet's last or first lanes lie outside them).
@pytest.mark.parametrize("target", [(12, 3, 13, 5), (5, 2, 11, 7)], ids=["right", "left-top"])
@pytest.mark.parametrize("packets", [False, True], ids=["one-pixel", "packets"])
def test_the_gather_adds_each_pixels_neighbours_records(packets, target):
    # Random records of 3 samples.
    import pyopencl as cl
    from clrender import layout, splatting

    device = clrender.choose_device(TEST_DEVICE)
    context = cl.Context([device])
    queue = cl.CommandQueue(context)
    gather = splatting.Gather(context, Filter("gaussian", stddev=0.5), packets=packets)
    reach, traced = gather.reach, (5, 2, 20, 7)
    samples = 3
    rng = np.random.default_rng(7)
    records = rng.uniform(0.0, 1.0, (samples, splatting.record_bytes(reach) // 4, traced[3] * traced[2])).astype(np.float32)
    start = rng.uniform(0.0, 1.0, (target[2] * target[3], 4)).astype(np.float32)
    params = np.zeros(1, layout.RENDER_PARAMS)
    params["frame"] = (40, 12, 0, samples)
    params["tile"], params["splat"], params["splat_reach"] = traced, target, (reach, 0, 0, 0)
    mf = cl.mem_flags
    params_buffer = cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=params)
    records_buffer = cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=records)
    filtered = cl.Buffer(context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=start)
    gather(queue, target, params_buffer, records_buffer, filtered)
    result = np.empty_like(start)
    cl.enqueue_copy(queue, result, filtered)
    # float32 sums of 3 x 25 products in [0, 1]: within a few ulps of the sums (at most 80).
    np.testing.assert_allclose(result, reference_gather(records, traced, target, reach, start), rtol=1e-5, atol=1e-5)
