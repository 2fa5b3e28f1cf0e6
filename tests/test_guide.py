"""The caustic guide (clrender/guide.py, kernels/guide.h, guide_photons.cl): diffuse sampling
drawn partly from cones towards where light from a directional light arrives through glossy glass.

The guided sampler against its own density (chi-square, and the density the kernel gives for
MIS); the lobes built from photon records (order-free, the strongest kept, weights closing at 1);
renders with and without the guide alike in expectation (per seed, the difference of the two
images' means within 5 standard errors; fixed seeds) and less noisy where the light crosses the
glass; the same bits however the samples are split. About 30 s on 2 cores.
"""
import math

import numpy as np
import pytest
import pyopencl as cl

import clrender
from clrender import guide, layout
from clrender.features import scene_features
from clrender.render import render_params
from conftest import assert_splits_keep_the_bits, build_test_kernels, z_bound


def upload(context, array):
    return cl.Buffer(context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(array))


def float4(rows):
    rows = np.asarray(rows, np.float32)
    return np.concatenate([rows, np.zeros((len(rows), 1), np.float32)], axis=1)


def glass_slab(guide_on=True, resolution=24, energy_compensation=False, **render):
    """A slab of rough glass (alpha 0.01) above a diffuse floor, lit by a directional light: the
    floor beneath the slab receives the light only through the glass, seen from above (through
    the slab too)."""
    return clrender.load_scene_dict({
        "camera": {"position": [0, 4, 0.001], "look_at": [0, 0, 0], "up": [0, 0, -1], "fov": 40,
                   "resolution": [resolution, resolution]},
        "render": {"max_depth": 8, "caustic_guide": guide_on, **render},
        "materials": [{"name": "floor", "type": "diffuse", "albedo": [0.8, 0.8, 0.8]},
                      {"name": "glass", "type": "dielectric", "ior": 1.5, "alpha": 0.01,
                       "energy_compensation": energy_compensation}],
        "shapes": [{"name": "floor", "type": "rectangle", "material": "floor",
                    "transform": {"scale": [3, 3, 1], "rotate": [-90, 0, 0]}},
                   {"name": "slab", "type": "box", "material": "glass",
                    "transform": {"scale": [0.8, 0.15, 0.8], "translate": [0, 0.8, 0]}}],
        "lights": [{"type": "directional", "direction": [0.3, -1, 0.2], "irradiance": 3}]})


# ----- the lobes from photon records -------------------------------------------------------------

def photon_records(points, directions, powers):
    """Records as guide_photons.cl writes them, photon i the i-th row."""
    records = np.zeros((len(points), guide.RECORD_FLOATS), np.float32)
    records[:, :3] = points
    records[:, 3] = powers
    records[:, 4:7] = np.asarray(directions, float) / np.linalg.norm(directions, axis=1, keepdims=True)
    records[:, 7] = np.arange(len(points), dtype=np.int32).view(np.float32)
    return records


def test_lobes_hold_the_strongest_directions_of_each_cell_with_their_share_of_the_light():
    rng = np.random.default_rng(4)
    # Cell A (near the origin): 6 directions of which the 4 brightest must stay; cell B (at the
    # far corner): one direction. The corners of the box make the grid's extent.
    directions = [[0, 0, 1], [1, 0, 1], [0, 1, 1], [-1, 0, 1], [0, -1, 1], [1, 1, 1], [1, -1, 2]]
    powers = [6.0, 5.0, 4.0, 3.0, 1.0, 0.5, 2.0]
    points = np.array([[0.01, 0.01, 0.01]] * 6 + [[3.19, 3.19, 3.19]])
    records = photon_records(points, directions, powers)
    lobes, grid, cells, cone = guide.build(records)
    assert cells[3] == 1 and cone[0] == guide.SHARE
    assert np.isclose(cone[1], math.cos(guide.CONE_HALF_ANGLE)) and np.isclose(cone[2], 1 / (2 * math.pi * (1 - cone[1])))
    edge = 1 / grid[3]

    def cell_lobes(point):
        index = np.floor((np.asarray(point) - grid[:3]) / edge).astype(int)
        cell = (index[2] * cells[1] + index[1]) * cells[0] + index[0]
        return lobes["direction"][cell * layout.GUIDE_LOBES:(cell + 1) * layout.GUIDE_LOBES]

    a = cell_lobes(points[0])
    unit = np.array(directions[:4], float) / np.linalg.norm(directions[:4], axis=1, keepdims=True)
    assert np.allclose(a[:, :3], unit, atol=1e-6)
    assert np.allclose(a[:, 3], np.cumsum(powers[:4]) / sum(powers[:4]), atol=1e-6) and a[-1, 3] == 1.0
    b = cell_lobes(points[-1])
    assert np.allclose(b[0, :3], np.array([1, -1, 2]) / math.sqrt(6), atol=1e-6) and np.all(b[:, 3] == 1.0)
    # Every other cell is empty; the records' order does not matter; bad records are left out.
    assert np.count_nonzero(lobes["direction"][:, 3]) == 2 * layout.GUIDE_LOBES
    shuffled = records[rng.permutation(len(records))]
    spoiled = np.concatenate([shuffled, photon_records([[np.nan, 0, 0], [1, 1, 1]], [[0, 0, 1], [0, 0, 1]], [1, 0])])
    again = guide.build(spoiled)
    assert np.array_equal(again[0], lobes) and again[1:] == (grid, cells, cone)
    assert guide.build(np.zeros((0, guide.RECORD_FLOATS), np.float32)) is None


# ----- the guided sampler ----------------------------------------------------------------------

def guided_params(axes, weights):
    """RenderParams and lobes of a guide of one cell, the unit cube at the origin."""
    scene = glass_slab()
    params = render_params(scene, clrender.arrays.build_scene_arrays(scene), 0, 1, 1, 1, 0)
    lobes = np.zeros(layout.GUIDE_LOBES, layout.GUIDE_LOBE)
    axes = np.asarray(axes, float) / np.linalg.norm(axes, axis=1, keepdims=True)
    lobes["direction"][:len(axes), :3] = axes
    lobes["direction"][:, 3] = 1.0
    lobes["direction"][:len(axes), 3] = np.cumsum(weights) / np.sum(weights)
    cos_cone = math.cos(guide.CONE_HALF_ANGLE)
    params["guide_grid"] = (0, 0, 0, 1)
    params["guide_cells"] = (1, 1, 1, 1)
    params["guide_cone"] = (guide.SHARE, cos_cone, 1 / (2 * math.pi * (1 - cos_cone)), 0)
    return params, lobes


def reference_pdf(wi, axes, weights, inside):
    """The mixture's density in float64 (normal +z): cosine and, inside the cell, the cones."""
    wi = np.asarray(wi, float)
    pdf = np.maximum(wi[:, 2], 0) / math.pi
    if inside:
        axes = np.asarray(axes, float) / np.linalg.norm(axes, axis=1, keepdims=True)
        shares = np.asarray(weights, float) / np.sum(weights)
        cos_cone = math.cos(guide.CONE_HALF_ANGLE)
        cones = ((wi @ axes.T) >= cos_cone) @ shares / (2 * math.pi * (1 - cos_cone))
        pdf = (1 - guide.SHARE) * pdf + guide.SHARE * cones
    return np.where(wi[:, 2] > 0, pdf, 0.0)


def sample_diffuse(queue, params, lobes, points, dirs, seed=7):
    program = build_test_kernels(queue.context)
    n = len(points)
    mf = cl.mem_flags
    out_wi = cl.Buffer(queue.context, mf.WRITE_ONLY, n * 16)
    out_pdf = cl.Buffer(queue.context, mf.WRITE_ONLY, n * 16)
    cl.Kernel(program, "sample_diffuse_values")(queue, (n,), None, upload(queue.context, params), upload(queue.context, lobes),
                                  upload(queue.context, float4(points)), upload(queue.context, float4(dirs)),
                                  np.uint32(seed), out_wi, out_pdf)
    wi, pdf = np.empty((n, 4), np.float32), np.empty((n, 4), np.float32)
    cl.enqueue_copy(queue, wi, out_wi)
    cl.enqueue_copy(queue, pdf, out_pdf)
    return wi[:, :3].astype(float), wi[:, 3].astype(float), pdf[:, 0].astype(float)


# Two cones: one steep, one grazing (part of it below the surface), one weighted 3:1.
AXES = [[0.3, -0.2, 1.0], [1.0, 0.0, 0.03]]
WEIGHTS = [3.0, 1.0]


def cone_frames(axes):
    axes = np.asarray(axes, float) / np.linalg.norm(axes, axis=1, keepdims=True)
    frames = []
    for axis in axes:
        t = np.cross(axis, [0.0, 1.0, 0.0])
        t /= np.linalg.norm(t)
        frames.append((t, np.cross(axis, t), axis))
    return frames


def direction_bins(w, axes):
    """16 bins in each cone (4 rings x 4 sectors; the first cone's where they overlap), 16 over
    the rest of the upper hemisphere ((cos theta)^2 x phi), one for the lower hemisphere."""
    index = np.full(len(w), -1)
    for k, (t, b, axis) in enumerate(cone_frames(axes)):
        angle = np.arccos(np.clip(w @ axis, -1, 1))
        turn = (np.arctan2(w @ b, w @ t) + math.pi) / (2 * math.pi)
        ring = np.minimum((angle / guide.CONE_HALF_ANGLE * 4).astype(int), 3)
        here = (angle < guide.CONE_HALF_ANGLE) & (index < 0)
        index[here] = 16 * (k + 1) + ring[here] * 4 + np.minimum((turn[here] * 4).astype(int), 3)
    rest = index < 0
    cos_theta = np.clip(w[:, 2], 0, 1 - 1e-12)
    phi = (np.arctan2(w[:, 1], w[:, 0]) + math.pi) / (2 * math.pi)
    index[rest] = np.minimum((cos_theta[rest] ** 2 * 4).astype(int), 3) * 4 + np.minimum((phi[rest] * 4).astype(int), 3)
    index[w[:, 2] <= 0] = 16 * (len(axes) + 1)
    return index


def reference_directions(rng, n, axes, weights, inside):
    """The mixture drawn in float64 by numpy: the cosine, and in the cell the cones (uniform in
    solid angle) with SHARE of the samples, chosen by weight."""
    u = rng.uniform(size=(n, 2))
    r, phi = np.sqrt(u[:, 0]), 2 * math.pi * u[:, 1]
    w = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - u[:, 0])], axis=1)
    if inside:
        guided = rng.uniform(size=n) < guide.SHARE
        cone = rng.choice(len(axes), size=n, p=np.asarray(weights) / np.sum(weights))
        v = rng.uniform(size=(n, 2))
        cos_t = 1 - v[:, 0] * (1 - math.cos(guide.CONE_HALF_ANGLE))
        sin_t = np.sqrt(1 - cos_t ** 2)
        for k, (t, b, axis) in enumerate(cone_frames(axes)):
            at = guided & (cone == k)
            p = 2 * math.pi * v[at, 1]
            w[at] = (sin_t[at] * np.cos(p))[:, None] * t + (sin_t[at] * np.sin(p))[:, None] * b + cos_t[at, None] * axis
    return w


@pytest.mark.parametrize("inside", [True, False])
def test_guided_diffuse_directions_follow_their_density(queue, inside):
    """Chi-square of the kernel's directions against the same mixture drawn by numpy (1M, its
    own noise in the expected counts small against the kernel's 200k), and the kernel's density
    (the sample's own and MIS's for any direction) against the mixture's in float64."""
    from scipy import stats

    params, lobes = guided_params(AXES, WEIGHTS)
    n = 200_000
    rng = np.random.default_rng(2)
    point = [0.5, 0.5, 0.5] if inside else [1.5, 0.5, 0.5]
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    wi, pdf_of_sample, pdf_of_dirs = sample_diffuse(queue, params, lobes, np.tile(point, (n, 1)), dirs)
    assert np.allclose(pdf_of_dirs, reference_pdf(dirs, AXES, WEIGHTS, inside), rtol=1e-4, atol=1e-6)
    assert np.allclose(pdf_of_sample, reference_pdf(wi, AXES, WEIGHTS, inside), rtol=1e-4, atol=1e-6)
    bins = 16 * (len(AXES) + 1) + 1
    observed = np.bincount(direction_bins(wi, AXES), minlength=bins)
    reference = direction_bins(reference_directions(rng, 1_000_000, AXES, WEIGHTS, inside), AXES)
    expected = np.bincount(reference, minlength=bins) / 1_000_000 * n
    keep = expected > 20
    assert observed[~keep].sum() <= max(20, 5 * expected[~keep].sum())
    chi2 = ((observed[keep] - expected[keep]) ** 2 / (expected[keep] * (1 + n / 1_000_000))).sum()
    assert stats.chi2.sf(chi2, keep.sum() - 1) > 1e-3
    if inside:   # the cones got their share
        assert observed[16:bins - 1].sum() > 0.2 * n


# ----- renders -------------------------------------------------------------------------------------

def renders(scene, device, packets, seeds, spp=32):
    renderer = clrender.Renderer(scene, device, packets=packets)
    return renderer, np.stack([renderer.render(spp=spp, seed=s).image for s in seeds]).astype(float)


@pytest.mark.parametrize("packets", [False, True])
def test_the_guide_keeps_the_image_and_lowers_the_noise_beneath_the_glass(device, packets):
    seeds = range(1, 17)
    renderer, guided = renders(glass_slab(True), device, packets, seeds)
    assert renderer.arrays.guide_cells[3] == 1 and renderer.features["LANES"] == (8 if packets else 1)
    _, cosine = renders(glass_slab(False), device, packets, seeds)
    assert z_bound(guided.mean(axis=(1, 2, 3)) - cosine.mean(axis=(1, 2, 3)), 0.0) < 5
    # Beneath the slab, seen through it: lit only through the glass.
    beneath = (slice(9, 19), slice(11, 20))
    region = [images[:, beneath[0], beneath[1]] for images in (guided, cosine)]
    assert z_bound(region[0].mean(axis=(1, 2, 3)) - region[1].mean(axis=(1, 2, 3)), 0.0) < 5
    assert region[0].var(axis=0, ddof=1).mean() < 0.25 * region[1].var(axis=0, ddof=1).mean()


def test_the_split_into_passes_and_tiles_keeps_the_bits(device):
    scene = glass_slab(True, resolution=16)
    renderer = clrender.Renderer(scene, device)
    assert_splits_keep_the_bits(renderer)
    # Another renderer of the scene (a Dask worker's) builds the same guide.
    assert np.array_equal(clrender.Renderer(scene, device).arrays.guide, renderer.arrays.guide)


@pytest.mark.parametrize("change,expected", [
    ({}, True),
    ({"caustic_guide": False}, False),
    ({"integrator": "direct"}, False),
])
def test_where_the_guide_applies(change, expected):
    scene = glass_slab(**change)
    assert guide.applies(scene, scene_features(scene)) is expected


def test_the_guide_needs_a_directional_light_and_glossy_glass_or_metal():
    scene = glass_slab()
    features = scene_features(scene)
    smooth = clrender.load_scene_dict({**_slab_dict(), "materials": [
        {"name": "floor", "type": "diffuse"}, {"name": "glass", "type": "dielectric", "ior": 1.5}]})
    assert not guide.applies(smooth, scene_features(smooth))
    metal = clrender.load_scene_dict({**_slab_dict(), "materials": [
        {"name": "floor", "type": "diffuse"}, {"name": "glass", "type": "conductor", "roughness": 0.2}]})
    assert guide.applies(metal, scene_features(metal))
    point = clrender.load_scene_dict({**_slab_dict(), "lights": [{"type": "point", "position": [0, 3, 0],
                                                                  "intensity": 5}]})
    assert not guide.applies(point, scene_features(point))
    assert guide.applies(scene, features)


def _slab_dict():
    return {"camera": {"position": [0, 4, 0.001], "look_at": [0, 0, 0], "up": [0, 0, -1], "resolution": [8, 8]},
            "materials": [{"name": "floor", "type": "diffuse"},
                          {"name": "glass", "type": "dielectric", "ior": 1.5, "alpha": 0.01}],
            "shapes": [{"type": "rectangle", "material": "floor", "transform": {"scale": 3, "rotate": [-90, 0, 0]}},
                       {"type": "box", "material": "glass", "transform": {"scale": [0.8, 0.15, 0.8],
                                                                          "translate": [0, 0.8, 0]}}],
            "lights": [{"type": "directional", "direction": [0.3, -1, 0.2], "irradiance": 3}]}
