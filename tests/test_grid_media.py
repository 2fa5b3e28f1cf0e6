"""Grid (heterogeneous) media: majorant grid, transmittance estimators and renders against
closed forms, by both methods (null-scattering path integral and ray marching).

Tolerances: |mean - expected| < 5 standard errors (conftest.z_bound), the standard error from
the spread of independent estimates (pixels, or work-items of a test kernel); fixed seeds, so
the outcomes are deterministic. Ray marching is biased: its tests bound the bias separately,
as stated at each.
"""
import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender import grids
from clrender.arrays import build_scene_arrays
from clrender.render import render_params
from conftest import build_test_kernels, camera, z_bound

BOUNDARY = {"name": "boundary", "type": "interface"}


def grid_medium(density, transform=None, **coefficients):
    medium = {"name": "m", "type": "grid", "density": density, **coefficients}
    if transform is not None:
        medium["transform"] = transform
    return medium


def box_scene(medium, camera_args=None, lights=None, render=None, extra_shapes=(), materials=()):
    """The medium inside an interface box [-1, 1]^3 (its grid transform chosen to match)."""
    return {
        "camera": camera(**(camera_args or {})),
        "media": [medium],
        "materials": [BOUNDARY, *materials],
        "shapes": [{"type": "box", "material": "boundary", "interior": medium["name"]}, *extra_shapes],
        "lights": lights if lights is not None else [{"type": "environment", "radiance": 1.0}],
        "render": render or {"max_depth": 64},
    }


UNIT_BOX = {"scale": 2, "translate": [-1, -1, -1]}   # the grid's unit cube onto [-1, 1]^3


# --------------------------------------------------------------------------------------------
# Test kernels: buffers of one scene's media
# --------------------------------------------------------------------------------------------
class MediaKernels:
    """The media buffers of `scene` on the test device, and the test kernels of one method."""

    def __init__(self, context, queue, scene, method, step=1.0, loosen=None):
        self.context, self.queue = context, queue
        self.program = build_test_kernels(context, MEDIA=1, GRID_MEDIA={"null": 1, "raymarch": 2}[method])
        arrays = build_scene_arrays(scene)
        if loosen:   # majorants `loosen` times too high, minorants 0: valid, but far from tight
            bounds = arrays.majorant_data.reshape(-1, 2)
            bounds[:, 0] *= loosen
            bounds[:, 1] = 0.0
        self.arrays = arrays
        params = render_params(scene, arrays, 0, 1, 1, 1, 0, step=step)
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        self.buffers = [cl.Buffer(context, flags, hostbuf=a)
                        for a in (params, arrays.media, arrays.grid_data, arrays.majorant_data)]
        self.kernels = {}

    def kernel(self, name):
        if name not in self.kernels:
            self.kernels[name] = cl.Kernel(self.program, name)
        return self.kernels[name]

    def output(self, shape, dtype):
        return np.empty(shape, dtype), cl.Buffer(self.context, cl.mem_flags.WRITE_ONLY,
                                                 int(np.prod(shape)) * np.dtype(dtype).itemsize)

    def input(self, array):
        return cl.Buffer(self.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                         hostbuf=np.ascontiguousarray(array))

    def fetch(self, host, device):
        cl.enqueue_copy(self.queue, host, device)
        return host

    def lookup(self, world):
        """(density, albedo) of medium 0 at world points (n, 3), as (n, 4) (grid_lookup)."""
        points = np.c_[world, np.zeros(len(world))].astype(np.float32)
        out, out_buffer = self.output((len(points), 4), np.float32)
        self.kernel("grid_lookup")(self.queue, (len(points),), None, *self.buffers, self.input(points), out_buffer)
        return self.fetch(out, out_buffer)

    def transmittance(self, origin, direction, t_max, count, seed=1, spectral_mis=True, kernel="transmittance_estimates"):
        out, out_buffer = self.output((count, 4), np.float32)
        self.kernel(kernel)(
            self.queue, (count,), None, *self.buffers, np.int32(0),
            np.array([*origin, 0], np.float32), np.array([*direction, 0], np.float32),
            np.float32(t_max), np.uint32(seed), np.int32(spectral_mis), out_buffer)
        return self.fetch(out, out_buffer)

    def walk(self, origins, directions, t_max, max_segments=256, samples=16, seed=3):
        n = len(origins)
        to4 = lambda a: np.concatenate([a, np.zeros((n, 1))], axis=1).astype(np.float32)
        segments, seg_buffer = self.output((n, max_segments, 4), np.float32)
        counts, count_buffer = self.output(n, np.int32)
        bounds, bound_buffer = self.output((n, 2), np.float32)
        self.kernel("majorant_walk")(self.queue, (n,), None, *self.buffers, np.int32(0),
                                   self.input(to4(origins)), self.input(to4(directions)),
                                   np.float32(t_max), np.int32(max_segments), np.int32(samples),
                                   np.uint32(seed), seg_buffer, count_buffer, bound_buffer)
        return self.fetch(segments, seg_buffer), self.fetch(counts, count_buffer), self.fetch(bounds, bound_buffer)


# --------------------------------------------------------------------------------------------
# Trilinear lookup and majorant grid
# --------------------------------------------------------------------------------------------
CLOUD_TRANSFORM = {"scale": [1.6, 1.2, 1.4], "rotate": [20, 35, -10], "translate": [-0.7, -0.5, -0.6]}


def cloud_scene(resolution=(40, 36, 44), block=8, seed=4, transform=CLOUD_TRANSFORM, sigma_t=(3.0, 5.0, 8.0)):
    medium = grid_medium({"procedural": "noise_cloud", "resolution": list(resolution), "seed": seed},
                         transform, sigma_t=list(sigma_t), albedo=0.9, majorant_block=block)
    return clrender.load_scene_dict(box_scene(medium))


def random_rays(scene, count, rng, inside_fraction=0.25):
    """Rays from a sphere around the grid towards random points of its box; some start inside."""
    grid = scene.media[0].grid
    targets = np.c_[rng.random((count, 3)), np.ones(count)] @ grid.to_world.T
    lo, hi = grid.world_bounds()
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo)
    away = rng.normal(size=(count, 3))
    origins = centre + radius * away / np.linalg.norm(away, axis=1, keepdims=True)
    inside = rng.random(count) < inside_fraction
    origins[inside] = (np.c_[rng.random((inside.sum(), 3)), np.ones(inside.sum())] @ grid.to_world.T)[:, :3]
    directions = targets[:, :3] - origins
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    directions[inside] = rng.normal(size=(inside.sum(), 3))
    directions[inside] /= np.linalg.norm(directions[inside], axis=1, keepdims=True)
    return origins, directions


def test_kernel_lookup_matches_the_reference_trilinear(context, queue):
    scene = cloud_scene()
    grid = scene.media[0].grid
    kernels = MediaKernels(context, queue, scene, "null")
    rng = np.random.default_rng(0)
    unit = rng.uniform(-0.05, 1.05, (4000, 3))           # some outside the box: density 0
    unit[:100] = rng.integers(0, 2, (100, 3)) * 1.0      # the corners themselves
    world = (np.c_[unit, np.ones(len(unit))] @ grid.to_world.T)[:, :3]
    out = kernels.lookup(world)
    expected = grids.trilinear(grid.density, unit)
    # float32 world -> voxel maps differ from float64 by ~1e-6 voxel; the density's slope is
    # bounded by its range, so 1e-4 is far above rounding and far below any indexing mistake.
    assert np.max(np.abs(out[:, 0] - expected)) < 1e-4
    assert np.all(out[np.any((unit < 0) | (unit > 1), axis=1), 0] == 0)
    assert np.all(out[:, 1:] == 0)   # no albedo grid


def test_kernel_albedo_lookup_matches_the_reference_trilinear(context, queue, tmp_path):
    # An RGB albedo grid at its own resolution in the density grid's unit cube; outside the cube
    # the lookup clamps (the density is 0 there anyway).
    albedo = np.random.default_rng(3).uniform(0, 1, (5, 3, 7, 3)).astype(np.float32)
    np.save(tmp_path / "albedo.npy", albedo)
    medium = grid_medium({"procedural": "noise_cloud", "resolution": [12, 10, 8]}, CLOUD_TRANSFORM,
                         sigma_t=2.0, albedo_grid={"file": str(tmp_path / "albedo.npy")})
    scene = clrender.load_scene_dict(box_scene(medium))
    kernels = MediaKernels(context, queue, scene, "null")
    rng = np.random.default_rng(1)
    unit = rng.uniform(-0.05, 1.05, (3000, 3))
    world = (np.c_[unit, np.ones(len(unit))] @ scene.media[0].grid.to_world.T)[:, :3]
    out = kernels.lookup(world)
    clamped = np.clip(unit, 0, 1)
    expected = np.stack([grids.trilinear(albedo[..., c], clamped) for c in range(3)], axis=1)
    assert np.max(np.abs(out[:, 1:] - expected)) < 1e-4   # as the density lookup's bound


def test_majorant_bounds_the_density_everywhere_and_segments_cover_nonempty_blocks(context, queue):
    scene = cloud_scene()
    grid = scene.media[0].grid
    kernels = MediaKernels(context, queue, scene, "null")
    rng = np.random.default_rng(1)
    origins, directions = random_rays(scene, 600, rng)
    segments, counts, bounds = kernels.walk(origins, directions, t_max=10.0)
    assert counts.max() < segments.shape[1]
    # Sampled densities never exceed the segment's majorant nor fall below its minorant (a
    # float32 rounding of the interpolation is allowed).
    assert bounds[:, 0].max() <= 1e-6 and bounds[:, 1].min() >= -1e-6
    high, low = grid.majorants()
    to_unit = np.linalg.inv(grid.to_world)
    nx, ny, nz = grid.resolution
    covered_nonempty = 0
    for i in range(len(origins)):
        segs = segments[i, :counts[i]]
        assert np.all(segs[:, 2] > 0), "a zero-majorant block was not skipped"
        assert np.all(np.diff(segs[:, 0]) > 0) and np.all(segs[:, 1] >= segs[:, 0])
        # Fine samples along the ray: inside a non-empty block <=> inside some segment (away from
        # block faces by a float margin), and a segment's majorant is its block's.
        t = np.linspace(0, 10.0, 3001)[1:-1]
        unit = (np.c_[origins[i] + t[:, None] * directions[i], np.ones(len(t))] @ to_unit.T)[:, :3]
        voxel = unit * [nx, ny, nz]
        inside = np.all((unit > 0) & (unit < 1), axis=1)
        block = np.clip((voxel // grid.block).astype(int), 0, np.array(high.shape[::-1]) - 1)
        majorant = np.where(inside, high[block[:, 2], block[:, 1], block[:, 0]], 0.0)
        which = np.searchsorted(segs[:, 0], t, side="right") - 1
        in_segment = (which >= 0) & (t < np.append(segs[:, 1], 0)[np.maximum(which, 0)])
        margin = np.min(np.abs(voxel / grid.block - np.round(voxel / grid.block)), axis=1) > 1e-3
        margin &= np.min(np.minimum(np.abs(unit), np.abs(1 - unit)), axis=1) > 1e-4
        assert np.array_equal(in_segment[margin], (majorant > 0)[margin])
        assert np.array_equal(segs[which[in_segment & margin], 2], majorant[in_segment & margin])
        covered_nonempty += int(np.sum(in_segment & margin))
    assert covered_nonempty > 10000  # the rays do cross the cloud


def test_majorant_grid_on_the_host_bounds_trilinear_samples():
    # Dense random sampling of the reference lookup against the host majorant grid, including
    # a grid whose size is not a multiple of the block and a 1x1x1 grid.
    rng = np.random.default_rng(2)
    for resolution, block in [((13, 7, 9), 4), ((1, 1, 1), 8), ((16, 16, 16), 16), ((30, 20, 10), 3)]:
        density = grids.noise_cloud(resolution, seed=3) * rng.random(resolution[::-1]).astype(np.float32)
        high, low = grids.block_bounds(density, block)
        unit = rng.random((20000, 3))
        value = grids.trilinear(density, unit)
        cell = np.minimum((unit * resolution // block).astype(int), np.array(high.shape[::-1]) - 1)
        assert np.all(value <= high[cell[:, 2], cell[:, 1], cell[:, 0]] + 1e-6)
        assert np.all(value >= low[cell[:, 2], cell[:, 1], cell[:, 0]] - 1e-6)


def test_empty_blocks_cost_no_lookup_and_majorants_are_tight(context, queue, tmp_path):
    # Density only in one corner block: a ray through the rest of the grid meets no segment,
    # and ratio and delta tracking make no tentative collision (transmittance exactly 1).
    density = np.zeros((32, 32, 32), np.float32)
    density[:8, :8, :8] = 5.0
    np.save(tmp_path / "corner.npy", density)
    scene = clrender.load_scene_dict(box_scene(grid_medium({"file": "corner.npy"}, UNIT_BOX, sigma_t=1.0,
                                                           albedo=0.5)), base_dir=tmp_path)
    kernels = MediaKernels(context, queue, scene, "null")
    origin, direction = (-2.0, 0.5, 0.5), (1.0, 0.0, 0.0)    # through blocks y, z >= 0.5: empty
    _, counts, _ = kernels.walk(np.array([origin]), np.array([direction]), t_max=10.0)
    assert counts[0] == 0
    for kernel in ("transmittance_estimates", "delta_pass_estimates"):
        estimates = kernels.transmittance(origin, direction, 10.0, 64, kernel=kernel)
        assert np.all(estimates[:, 3] == 0) and np.all(estimates[:, :3] == 1.0)
    # Tight majorants: through a cloud, per-block majorants (and minorants) need far fewer
    # tentative collisions of ratio tracking than one bound for the whole grid, for the same
    # (unbiased) expectation.
    collisions, means = {}, {}
    for block in (4, 1024):
        scene = cloud_scene(block=block, sigma_t=(0.5, 0.7, 1.0))  # thin: rays get through
        kernels = MediaKernels(context, queue, scene, "null")
        lo, hi = scene.media[0].grid.world_bounds()
        estimates = kernels.transmittance(lo - 0.1, (hi - lo) / np.linalg.norm(hi - lo),
                                          np.linalg.norm(hi - lo) + 0.2, 20000)
        collisions[block] = estimates[:, 3].mean()
        means[block] = estimates[:, :3]
    assert collisions[4] < 0.6 * collisions[1024]
    for c in range(3):
        assert z_bound(means[4][:, c] - means[1024][:, c], 0.0) < 5.0


# --------------------------------------------------------------------------------------------
# Transmittance through a linear gradient: closed form
# --------------------------------------------------------------------------------------------
SIGMA_T = np.array([0.6, 1.2, 2.4])
LENGTH = 2.0


def gradient_scene(block=4):
    # 32 samples along x with values 2 * (i + 0.5) / 32: the trilinear density is exactly
    # 2 * x / LENGTH (world x in [0, LENGTH]) between the outermost sample centres, constant
    # across y and z.
    medium = grid_medium({"procedural": "gradient", "resolution": [32, 8, 8], "axis": 0, "high": 2.0},
                         {"scale": [LENGTH, 1, 1], "translate": [0, -0.5, -0.5]},
                         sigma_a=(SIGMA_T * 0.25).tolist(), sigma_s=(SIGMA_T * 0.75).tolist(),
                         majorant_block=block)
    return clrender.load_scene_dict(box_scene(medium))


def gradient_ray():
    """An oblique ray inside the linear part; returns origin, unit direction, length, expected T."""
    start = np.array([LENGTH / 32 * 1.5, -0.4, -0.3])
    end = np.array([LENGTH * (1 - 1.5 / 32), 0.4, 0.35])
    length = np.linalg.norm(end - start)
    mean_density = 2.0 * (start[0] + end[0]) / 2 / LENGTH      # linear: the midpoint value
    return start, (end - start) / length, length, np.exp(-SIGMA_T * mean_density * length)


@pytest.mark.parametrize("spectral_mis", [True, False])
def test_ratio_tracking_matches_the_closed_form_transmittance(context, queue, spectral_mis):
    kernels = MediaKernels(context, queue, gradient_scene(), "null")
    origin, direction, length, expected = gradient_ray()
    estimates = kernels.transmittance(origin, direction, length, 40000, seed=5, spectral_mis=spectral_mis)
    assert np.all(np.isfinite(estimates))
    assert estimates[:, 3].mean() > 0.3   # residual ratio tracking does collide here
    for c in range(3):
        assert z_bound(estimates[:, c], expected[c]) < 5.0, (c, estimates[:, c].mean(), expected[c])


@pytest.mark.parametrize("block,loosen", [(8, None), (1024, None), (8, 4.0)])
def test_ratio_tracking_through_a_thick_cloud_matches_quadrature(context, queue, block, loosen):
    # Rays through a chromatic noise cloud, transmittances from 0.3 down to 1e-3, against the
    # midpoint rule (20000 points) on the reference lookup. Block 1024 is one bound for the whole
    # grid; loosened majorants (4x, minorant 0) make every collision a partial one, so the
    # hero's estimate decays slowly and ratio tracking's roulette runs on most rays.
    scene = cloud_scene(block=block)
    grid = scene.media[0].grid
    kernels = MediaKernels(context, queue, scene, "null", loosen=loosen)
    sigma_t = scene.media[0].sigma_a + scene.media[0].sigma_s
    to_unit = np.linalg.inv(grid.to_world)
    for k, (a, b) in enumerate([((0.5, 0.0, 0.5), (0.5, 1.0, 0.5)), ((0.0, 0.45, 0.2), (1.0, 0.55, 0.8)),
                                ((0.2, 0.3, 1.0), (0.8, 0.6, 0.0))]):
        start, end = (grid.to_world @ [*a, 1])[:3], (grid.to_world @ [*b, 1])[:3]
        length = np.linalg.norm(end - start)
        t = (np.arange(20000) + 0.5) / 20000 * length
        points = start + (t / length)[:, None] * (end - start)
        unit = (np.c_[points, np.ones(len(t))] @ to_unit.T)[:, :3]
        expected = np.exp(-sigma_t * grids.trilinear(grid.density, unit).sum() * length / len(t))
        estimates = kernels.transmittance(start, (end - start) / length, length, 20000, seed=30 + k)
        assert np.all(np.isfinite(estimates)) and expected.min() < 0.05
        for c in range(3):
            assert z_bound(estimates[:, c], expected[c]) < 5.0, (k, c, estimates[:, c].mean(), expected[c])


@pytest.mark.parametrize("kind", ["homogeneous", "constant_grid"])
def test_shadow_rays_through_constant_media_are_exact(context, queue, kind):
    # Where the majorant equals the minorant (every homogeneous medium; constant blocks of a grid)
    # residual ratio tracking has no tentative collision: the estimate is exp(-sigma_t d) itself,
    # without variance, as the analytic transmittance of scenes without grid media.
    sigma_t = np.array([0.5, 1.0, 3.0])
    medium = {"name": "m", "sigma_a": (sigma_t / 2).tolist(), "sigma_s": (sigma_t / 2).tolist()}
    if kind == "constant_grid":
        medium.update(constant_grid())
    kernels = MediaKernels(context, queue, clrender.load_scene_dict(box_scene(medium)), "null")
    estimates = kernels.transmittance((-0.9, -0.2, 0.1), (1.0, 0.0, 0.0), 1.7, 256)
    assert np.all(estimates[:, 3] == 0)
    assert np.allclose(estimates[:, :3], np.exp(-sigma_t * 1.7), rtol=1e-5, atol=0)


def test_delta_tracking_passes_with_the_transmittance_per_channel(context, queue):
    # Passing probability of the mixture over heroes, times the chain weight, estimates T_c.
    kernels = MediaKernels(context, queue, gradient_scene(), "null")
    origin, direction, length, expected = gradient_ray()
    estimates = kernels.transmittance(origin, direction, length, 40000, seed=6, kernel="delta_pass_estimates")
    for c in range(3):
        assert z_bound(estimates[:, c], expected[c]) < 5.0, (c, estimates[:, c].mean(), expected[c])


def test_ray_marching_error_shrinks_with_the_step(context, queue):
    scene = gradient_scene()
    origin, direction, length, expected = gradient_ray()
    errors, biases = [], []
    for step in (4.0, 2.0, 1.0, 0.5, 0.25):   # voxels (shadow rays march twice as long steps)
        kernels = MediaKernels(context, queue, scene, "raymarch", step=step)
        estimates = kernels.transmittance(origin, direction, length, 20000, seed=7)[:, :3]
        errors.append(np.sqrt(np.mean((estimates - expected) ** 2)))
        biases.append(np.abs(estimates.mean(axis=0) - expected).max())
    assert all(a > b for a, b in zip(errors, errors[1:])), errors
    # At the finest step the marched transmittance is within 0.5% of the closed form.
    assert biases[-1] < 0.005 * expected.min() + 5 * errors[-1] / np.sqrt(20000), biases


# --------------------------------------------------------------------------------------------
# Renders
# --------------------------------------------------------------------------------------------
def loosen_majorants(renderer, factor=3.0):
    """Majorants `factor` times too high and minorants 0: still valid bounds, so the same
    expectation, but reached through many null collisions (delta tracking) and tentative
    collisions (ratio tracking) whose pdfs enter every MIS weight."""
    bounds = renderer.arrays.majorant_data.reshape(-1, 2).copy()
    bounds[:, 0] *= factor
    bounds[:, 1] = 0.0
    renderer.update_array("majorant_data", bounds.ravel())


LIT_BOX = dict(
    camera_args={"position": (0, 0.6, 4.5), "look_at": (0, -0.1, 0), "fov": 42, "resolution": (24, 24)},
    lights=[{"type": "environment", "radiance": [0.3, 0.35, 0.4]},
            {"type": "point", "position": [1.5, 2.0, 1.5], "intensity": 3.0}],
    extra_shapes=[{"type": "rectangle", "material": "floor", "transform": {"scale": 3, "rotate": [-90, 0, 0],
                                                                          "translate": [0, -1.2, 0]}},
                  {"type": "rectangle", "material": "lamp", "transform": {"scale": 0.5, "rotate": [90, 0, 0],
                                                                         "translate": [-0.5, 2.0, 0]}}],
    materials=[{"name": "floor", "type": "diffuse", "albedo": [0.6, 0.6, 0.6]},
               {"name": "lamp", "type": "emissive", "radiance": [6.0, 5.0, 4.0]}],
    render={"max_depth": 12, "rr_depth": 4},
)
CHROMATIC = {"sigma_t": [1.0, 2.0, 4.0], "albedo": [0.9, 0.8, 0.7], "g": 0.4}


def lit_box(medium):
    return clrender.load_scene_dict(box_scene(dict(name="m", **medium), **LIT_BOX))


def constant_grid(resolution=(3, 3, 3)):
    return {"type": "grid", "density": {"procedural": "constant", "resolution": list(resolution)},
            "transform": UNIT_BOX}


def assert_same_expectation(a, b, sigmas=5.0):
    """Two independent renders agree: per channel, the mean pixel difference within `sigmas` SE."""
    assert a.discarded_samples == 0 and b.discarded_samples == 0
    for c in range(3):
        difference = a.image[..., c] - b.image[..., c]
        assert z_bound(difference, 0.0) < sigmas, (c, a.image[..., c].mean(), b.image[..., c].mean())


@pytest.mark.parametrize("loose", [False, True], ids=["tight", "loose_majorants"])
def test_constant_grid_renders_as_the_homogeneous_medium_null_scattering(device, loose):
    # A chromatic, anisotropic medium lit by an environment, a point light and an area light,
    # above a diffuse floor: camera rays, surface and medium NEE through the medium, and MIS
    # with emitters hit. The constant grid equals the homogeneous medium; with loose majorants
    # every weight runs through null-collision pdfs.
    homogeneous = clrender.Renderer(lit_box(CHROMATIC), device).render(spp=128, seed=11)
    renderer = clrender.Renderer(lit_box({**CHROMATIC, **constant_grid()}), device)
    assert renderer.features["GRID_MEDIA"] == 1
    if loose:
        loosen_majorants(renderer)
    grid = renderer.render(spp=128, seed=12)
    assert_same_expectation(homogeneous, grid)


def test_constant_grid_renders_as_the_homogeneous_medium_ray_marching(device):
    # For a constant density ray marching is exact: every step holds the one density, so free
    # flight, transmittance and their pdfs are those of the homogeneous medium.
    homogeneous = clrender.Renderer(lit_box(CHROMATIC), device).render(spp=24, seed=13)
    renderer = clrender.Renderer(lit_box({**CHROMATIC, **constant_grid()}), device, volume_method="raymarch")
    assert renderer.features["GRID_MEDIA"] == 2
    assert_same_expectation(homogeneous, renderer.render(spp=24, seed=14))


def thick_ball(**albedo):
    """A dense chromatic ball of medium in a uniform environment: the image depends on the
    albedo through many scattering orders."""
    medium = {"name": "m", "type": "grid", "sigma_t": [20.0, 30.0, 40.0], "g": 0.4, "transform": UNIT_BOX,
              "density": {"procedural": "sphere_falloff", "resolution": [8, 8, 8]}, **albedo}
    return clrender.load_scene_dict(box_scene(medium, camera_args={"resolution": (16, 16), "fov": 30},
                                              render={"max_depth": 64}))


@pytest.mark.parametrize("method", ["null", "raymarch"])
def test_a_constant_albedo_grid_renders_as_the_constant_albedo(device, tmp_path, method):
    # Chromatic albedos from a 2 x 3 x 2 grid of equal samples: sigma_t split by them at every
    # collision gives the medium of that constant albedo (scattering, absorption, MIS weights).
    # The test notices a change of the red albedo by 0.02 (raymarch) to 0.05 (null).
    albedo = [0.9, 0.8, 0.7]
    np.save(tmp_path / "albedo.npy", np.broadcast_to(albedo, (2, 3, 2, 3)).astype(np.float32))
    constant = clrender.Renderer(thick_ball(albedo=albedo), device, volume_method=method)
    grid = clrender.Renderer(thick_ball(albedo_grid={"file": str(tmp_path / "albedo.npy")}), device, volume_method=method)
    assert_same_expectation(constant.render(spp=256, seed=21), grid.render(spp=256, seed=22))


FOG = {"sigma_a": [0.05, 0.1, 0.2], "sigma_s": [0.25, 0.2, 0.1], "g": -0.2}


def lit_box_in_fog(medium, fog):
    """lit_box inside a chromatic fog sphere: path and shadow rays cross the fog, the box's
    boundary, the box's medium and back, so MIS weights multiply the pdf ratios of segments of
    both media."""
    data = box_scene(dict(name="m", **medium), **LIT_BOX)
    data["media"].append({"name": "fog", **FOG, **fog})
    data["shapes"][0]["exterior"] = "fog"
    data["shapes"][1]["transform"] = {"scale": 2, "rotate": [-90, 0, 0], "translate": [0, -1.2, 0]}
    data["shapes"][2]["transform"] = {"scale": 0.5, "rotate": [90, 0, 0], "translate": [-0.5, 1.8, 0]}
    for shape in data["shapes"][1:]:
        shape["exterior"] = "fog"
    data["shapes"].append({"type": "sphere", "material": "boundary", "interior": "fog", "radius": 2.2})
    return clrender.load_scene_dict(data)


@pytest.mark.parametrize("method", ["null", "raymarch"])
def test_mixed_media_keep_their_mis_weights_consistent(device, method):
    # The same constant media three ways: all homogeneous (a kernel without grid media: analytic
    # free flight and transmittance), all constant grids (every segment by the grid estimator;
    # null scattering with majorants loosened 3x, so every weight goes through null-collision
    # pdfs), and mixed (homogeneous fog, grid box: each segment sampled by its own estimator and
    # hero). MIS weights are unbiased only if both techniques multiply the same pdf ratios for
    # every segment; a ratio dropped or changed on one side for one kind of medium biases the
    # renders using that kind and not the others (checked by breaking each on purpose).
    fog_grid = {"type": "grid", "density": {"procedural": "constant", "resolution": [2, 2, 2]},
                "transform": {"scale": 4.4, "translate": [-2.2, -2.2, -2.2]}}
    renders = []
    for box, fog in [({}, {}), (constant_grid(), fog_grid), (constant_grid(), {})]:
        renderer = clrender.Renderer(lit_box_in_fog({**CHROMATIC, **box}, fog), device, volume_method=method)
        assert renderer.features["GRID_MEDIA"] == (0 if not box else {"null": 1, "raymarch": 2}[method])
        if method == "null" and box:
            loosen_majorants(renderer)
        renders.append(renderer.render(spp=96, seed=15 + len(renders)))
    assert_same_expectation(renders[0], renders[1])
    assert_same_expectation(renders[0], renders[2])


def sun_slab(density, thickness, sigma_a, sigma_s, g, irradiance):
    """A slab y in [-thickness, 0] of a grid medium, a camera and the sun straight above it."""
    medium = grid_medium(density, {"scale": [8, thickness, 8], "translate": [-4, -thickness, -4]},
                         sigma_a=sigma_a.tolist(), sigma_s=sigma_s.tolist(), g=g)
    data = box_scene(medium, camera_args={"position": (0, 3, 0), "look_at": (0, 0, 0), "up": (0, 0, -1),
                                          "fov": 4, "resolution": (24, 24)},
                     lights=[{"type": "directional", "direction": [0, -1, 0], "irradiance": irradiance}],
                     render={"max_depth": 2})
    data["shapes"][0]["transform"] = {"scale": [4, thickness / 2, 4], "translate": [0, -thickness / 2, 0]}
    return clrender.load_scene_dict(data)


GRADED_SLAB = dict(thickness=0.8, irradiance=2.0, g=0.3, sigma_a=np.array([0.3, 0.1, 1.0]),
                   sigma_s=np.array([1.5, 0.6, 0.4]),
                   density={"procedural": "gradient", "resolution": [2, 16, 2], "axis": 1, "low": 2.0, "high": 0.2})


def graded_slab_single_scattering(scene, thickness, irradiance, g, sigma_a, sigma_s, samples=4000, subpixels=4):
    """The closed form of single scattering from the slab, per channel, averaged over the image:
    for a view ray at cosine mu to the vertical (camera and sun straight above),
        L = E p_HG(-mu) integral_0^H sigma_s d(s) exp(-sigma_t D(s) (1 + 1 / mu)) ds / mu,
    D(s) the density integrated from the top down to depth s; 1D integrals by the midpoint rule
    on the reference lookup, mu over a sub-pixel grid of every pixel."""
    depth = (np.arange(samples) + 0.5) / samples * thickness
    column = np.c_[np.full(samples, 0.5), 1 - depth / thickness, np.full(samples, 0.5)]
    d = grids.trilinear(scene.media[0].grid.density, column)
    optical = np.cumsum(d) * (thickness / samples) - d * (thickness / samples) / 2
    width, _ = scene.camera.resolution
    offsets = (np.arange(subpixels) + 0.5) / subpixels
    s = 2 * (np.arange(width)[:, None] + offsets[None, :]).ravel() / width - 1
    tan_half = np.tan(np.radians(scene.camera.fov) / 2)
    mu = (1 / np.sqrt(1 + (s[:, None] ** 2 + s[None, :] ** 2) * tan_half ** 2)).ravel()[:, None]
    phase = (1 - g * g) / (4 * np.pi * (1 + g * g + 2 * g * mu[:, 0]) ** 1.5)   # at cos = -mu
    sigma_t = sigma_a + sigma_s
    return np.array([np.mean(irradiance * phase * np.sum(
        sigma_s[c] * d * np.exp(-sigma_t[c] * optical * (1 + 1 / mu)) / mu, axis=1) * thickness / samples)
        for c in range(3)])


def test_single_scattering_from_a_graded_slab_lit_by_the_sun_null_scattering(device):
    # Density rising linearly with depth (a gradient grid along y); camera and sun look straight
    # down; max depth 2 is single scattering, by next-event estimation only (the sun is a delta).
    scene = sun_slab(GRADED_SLAB["density"], *(GRADED_SLAB[k] for k in ("thickness", "sigma_a", "sigma_s", "g",
                                                                         "irradiance")))
    expected = graded_slab_single_scattering(scene, **{k: v for k, v in GRADED_SLAB.items() if k != "density"})
    result = clrender.Renderer(scene, device, volume_method="null").render(spp=48, seed=21)
    assert result.discarded_samples == 0
    for c in range(3):
        assert z_bound(result.image[..., c], expected[c]) < 5.0, (c, result.image[..., c].mean(), expected[c])


@pytest.mark.parametrize("multiple_scattering", [False, True], ids=["single_scattering", "max_depth_2"])
def test_ray_marched_single_scattering_matches_the_closed_form(device, multiple_scattering):
    # The same slab by ray marching at its default step (2 voxels: 1/8 of the slab). The
    # single-scattering option ends every path after the light sample at its first scattering
    # vertex, so even at a large max depth it renders the closed form; with multiple scattering,
    # max depth 2 does. Marching's bias here (stratified density, optical depth <= 0.2 per step)
    # is far below the noise: within 5 standard errors.
    keys = ("thickness", "sigma_a", "sigma_s", "g", "irradiance")
    scene = sun_slab(GRADED_SLAB["density"], *(GRADED_SLAB[k] for k in keys))
    expected = graded_slab_single_scattering(scene, **{k: v for k, v in GRADED_SLAB.items() if k != "density"})
    renderer = clrender.Renderer(scene, device, volume_method="raymarch",
                                 raymarch_multiple_scattering=multiple_scattering)
    result = renderer.render(spp=64, seed=5, max_depth=2 if multiple_scattering else 64)
    assert result.discarded_samples == 0
    for c in range(3):
        assert z_bound(result.image[..., c], expected[c]) < 5.0, (c, result.image[..., c].mean(), expected[c])


def sunlit_cloud(scale=1.0, resolution=20):
    """A chromatic cloud in a box, lit by the sky and a sun, every length times `scale` (and the
    coefficients divided by it, so the image is the same at any scale)."""
    medium = grid_medium({"procedural": "noise_cloud", "resolution": [24, 20, 24], "seed": 5},
                         {"scale": 2 * scale, "translate": [-scale, -scale, -scale]},
                         sigma_t=[sigma / scale for sigma in (10.0, 14.0, 20.0)], albedo=[0.95, 0.9, 0.85], g=0.5)
    data = box_scene(medium, camera_args={"position": (0, 0.5 * scale, 4 * scale), "look_at": (0, 0, 0), "fov": 35,
                                          "resolution": (resolution, resolution)},
                     lights=[{"type": "environment", "radiance": [0.2, 0.25, 0.3]},
                             {"type": "directional", "direction": [-0.5, -1, -0.3], "irradiance": [3.0, 2.5, 2.0]}],
                     render={"max_depth": 32, "rr_depth": 6})
    data["shapes"][0]["transform"] = {"scale": scale}
    return clrender.load_scene_dict(data)


def test_ray_marching_converges_to_null_scattering_as_the_step_shrinks(device):
    # Multiple scattering in a dense chromatic cloud (up to ~1 optical depth per voxel). The
    # image mean's relative error against null scattering: clearly biased at 16 voxels per step
    # (the density held constant over coarse steps: Jensen's inequality makes the marched
    # transmittance too high), smaller at 8, and within 5 standard errors of the two renders'
    # noise at 1 voxel (measured, worst channel: 4.2%, 1.9%, 0.8% with z = 1.6; 16 s).
    scene = sunlit_cloud()
    reference = clrender.Renderer(scene, device, volume_method="null").render(spp=384, seed=1).image
    errors = []
    for step in (16.0, 8.0, 1.0):
        image = clrender.Renderer(scene, device, volume_method="raymarch", step=step).render(spp=384, seed=2).image
        difference = image - reference
        errors.append(max(abs(difference[..., c].mean()) / reference[..., c].mean() for c in range(3)))
        z = max(z_bound(difference[..., c], 0.0) for c in range(3))
        assert (z > 5.0) if step == 16.0 else True, (step, z)
    assert errors[0] > errors[1] > errors[2], errors
    assert z < 5.0, errors


def test_ray_marching_renders_a_scene_scaled_by_1000_the_same(device):
    # Steps are measured in voxels and optical depths, so scaling every length by 1000 (and the
    # coefficients by 1/1000) changes nothing but rounding (an absolute step of 0.02 took 1000
    # times more steps, or hit a step cap, in the large scene).
    images = [clrender.Renderer(sunlit_cloud(scale), device, volume_method="raymarch").render(spp=16, seed=3).image
              for scale in (1.0, 1000.0)]
    assert np.sqrt(np.mean((images[0] - images[1]) ** 2)) < 1e-3 * np.sqrt(np.mean(images[0] ** 2))


@pytest.mark.parametrize("mixed", [False, True], ids=["cloud", "cloud_in_fog"])
def test_furnace_albedo_one_cloud_vanishes(device, mixed):
    # A lossless (albedo 1), chromatic, forward-scattering cloud in a uniform environment of
    # radiance 1: every pixel is 1 whatever the density. "cloud_in_fog" puts the cloud inside a
    # lossless homogeneous fog sphere, so chains cross both kinds of media and a boundary.
    medium = {"name": "cloud", "type": "grid", "sigma_t": [6.0, 10.0, 16.0], "albedo": 1.0, "g": 0.6,
              "density": {"procedural": "noise_cloud", "resolution": [24, 20, 24], "seed": 2},
              "transform": UNIT_BOX}
    data = box_scene(medium, camera_args={"resolution": (16, 16), "fov": 26},
                     render={"max_depth": 1000, "rr_depth": 5})
    if mixed:
        data["media"].append({"name": "fog", "sigma_t": [0.3, 0.5, 0.8], "albedo": 1.0, "g": -0.3})
        data["shapes"][0]["exterior"] = "fog"
        data["shapes"].append({"type": "sphere", "material": "boundary", "interior": "fog", "radius": 2.2})
    scene = clrender.load_scene_dict(data)
    renderer = clrender.Renderer(scene, device)
    transmitted = renderer.render(spp=8, seed=1, max_depth=1).image
    assert transmitted.min() < 0.2   # the cloud is thick: most light reaching the camera scattered
    result = renderer.render(spp=32, seed=4)
    assert result.discarded_samples == 0
    for c in range(3):
        assert z_bound(result.image[..., c], 1.0) < 5.0, (c, result.image[..., c].mean())


def test_a_lossless_channel_is_not_ended_by_the_others_absorption(device):
    # A grey cloud of albedo 1 in red and 0.5 in green and blue, in a uniform environment of
    # radiance 1, without light samples in it and without roulette: a red path leaves the cloud
    # with weight exactly 1 (the hero's spectral-MIS ratios are 1 for a grey sigma_t, and a real
    # collision weighs the path by its albedo), so every red pixel is 1 to rounding. Absorption
    # drawn as an event with a green or blue hero's probabilities ended red paths too (unbiased,
    # but noisy: 2.7x Mitsuba's variance on test-hetero-volume).
    medium = {"name": "cloud", "type": "grid", "sigma_t": 3.0, "albedo": [1.0, 0.5, 0.5], "g": 0.3,
              "sample_emitters": False, "transform": UNIT_BOX,
              "density": {"procedural": "noise_cloud", "resolution": [16, 16, 16], "seed": 5}}
    data = box_scene(medium, camera_args={"resolution": (8, 8), "fov": 26},
                     render={"max_depth": 5000, "rr_depth": 5000})
    result = clrender.Renderer(clrender.load_scene_dict(data), device).render(spp=16, seed=2)
    assert result.discarded_samples == 0
    np.testing.assert_allclose(result.image[..., 0], 1.0, rtol=1e-5)
    assert result.image[..., 1:].min() < 0.8   # the other channels do lose light


@pytest.mark.parametrize("method", ["null", "raymarch"])
def test_camera_inside_a_cloud_sees_an_attenuated_lamp(device, method):
    # Top-level grid medium (no boundary shape): a constant absorbing grid over [-2, 2]^3 with
    # the camera at its centre, a lamp of radiance 3 at distance 1.5 inside it. Max depth 1:
    # pixel = 3 exp(-sigma_a 1.5) (paths at fov 5 are < 0.1% longer).
    sigma_a = np.array([0.2, 0.6, 1.4])
    data = {
        "camera": camera(position=(0, 0, 0), look_at=(0, 0, -1), fov=5, resolution=(8, 8)),
        "media": [{"name": "m", "type": "grid", "sigma_a": sigma_a.tolist(),
                   "density": {"procedural": "constant", "resolution": [5, 5, 5]},
                   "transform": {"scale": 4, "translate": [-2, -2, -2]}}],
        "medium": "m",
        "materials": [{"name": "lamp", "type": "emissive", "radiance": 3.0}],
        "shapes": [{"type": "rectangle", "material": "lamp", "transform": {"translate": [0, 0, -1.5]}}],
        "render": {"max_depth": 1},
    }
    scene = clrender.load_scene_dict(data)
    renderer = clrender.Renderer(scene, device, volume_method=method)
    assert renderer.arrays.camera_medium == 0
    result = renderer.render(spp=32, seed=3)
    assert result.discarded_samples == 0
    # Per pixel: the distance to the lamp plane is 1.5 / cos(angle off the axis), averaged over
    # a sub-pixel grid (corner paths are 0.2% longer than the axis).
    offsets = (np.arange(8) + 0.5) / 8
    sx = 2 * (np.arange(8)[:, None] + offsets[None, :]).ravel() / 8 - 1
    tan_half = np.tan(np.radians(5) / 2)
    secant = np.sqrt(1 + (sx[:, None] ** 2 + sx[None, :] ** 2) * tan_half ** 2).reshape(8, 8, 8, 8)
    for c in range(3):
        expected = 3.0 * np.exp(-sigma_a[c] * 1.5 * secant).mean(axis=(1, 3))
        assert z_bound(result.image[..., c] - expected, 0.0) < 5.0   # marching: exact for a constant density


HARD_MEDIA = {
    "zero_density": ({"procedural": "constant", "resolution": [4, 4, 4], "value": 0.0}, {"sigma_t": 5.0, "albedo": 0.8}, {}),
    "huge_density": ({"procedural": "sphere_falloff", "resolution": [16, 16, 16]}, {"sigma_t": 1e4, "albedo": 0.5}, {}),
    "huge_lossless": ({"procedural": "sphere_falloff", "resolution": [16, 16, 16]}, {"sigma_t": 1e4, "albedo": 1.0},
                      {"max_depth": 40, "rr_depth": 100}),
    "tiny_grid": ({"procedural": "constant", "resolution": [1, 1, 1], "value": 2.0}, {"sigma_t": 3.0, "albedo": 0.9}, {}),
    "transparent_channels": ({"procedural": "noise_cloud", "resolution": [12, 12, 12]},
                             {"sigma_a": [0, 0, 5], "sigma_s": [0, 2, 0]}, {}),
    "peaked_phase": ({"procedural": "noise_cloud", "resolution": [12, 12, 12]}, {"sigma_t": 4.0, "albedo": 0.9, "g": 0.999}, {}),
    "g_rounds_to_one": ({"procedural": "noise_cloud", "resolution": [12, 12, 12]},
                        {"sigma_t": 4.0, "albedo": 0.9, "g": -0.99999999}, {}),
}


@pytest.mark.parametrize("method", ["null", "raymarch"])
@pytest.mark.parametrize("case", list(HARD_MEDIA))
def test_hard_grid_media_stay_finite(device, method, case):
    density, coefficients, render = HARD_MEDIA[case]
    medium = grid_medium(density, UNIT_BOX, **coefficients)
    data = box_scene(medium, camera_args={"resolution": (10, 10)}, render={"max_depth": 16, **render},
                     lights=[{"type": "environment", "radiance": 1.0},
                             {"type": "point", "position": [0, 3, 0], "intensity": 5.0}])
    renderer = clrender.Renderer(clrender.load_scene_dict(data), device, volume_method=method)
    # Marching reports media too dense for its step refinement (1250 optical depths per voxel).
    assert bool(renderer.notes) == (method == "raymarch" and case.startswith("huge")), renderer.notes
    result = renderer.render(spp=4, seed=1)
    assert result.discarded_samples == 0
    assert np.all(np.isfinite(result.image)) and np.all(result.image >= 0)
    if case == "zero_density":   # nothing there: the environment seen unchanged
        assert np.allclose(result.image, 1.0)


@pytest.mark.parametrize("method", ["null", "raymarch"])
def test_rays_grazing_the_grid_box(device, method):
    # The camera sits in the plane of the grid box's top face (y = 1) and looks along it: rays
    # going up never enter, rays going down enter through the side face and cross the box; the
    # middle row of the image holds rays (nearly) in the plane. A second view looks along an
    # edge. No interface shape: the grid is the top-level medium, so the DDA's box test decides.
    medium = {"name": "m", "type": "grid", "sigma_a": 4.0,
              "density": {"procedural": "constant", "resolution": [4, 4, 4]}, "transform": UNIT_BOX}
    for position, look_at in [((-4, 1, 0), (0, 1, 0)), ((-4, 1, 1), (4, 1, 1))]:
        data = {"camera": camera(position=position, look_at=look_at, fov=3, resolution=(9, 9)),
                "media": [medium], "medium": "m", "materials": [],
                "lights": [{"type": "environment", "radiance": 1.0}], "render": {"max_depth": 8}}
        renderer = clrender.Renderer(clrender.load_scene_dict(data), device, volume_method=method)
        spp = 4
        result = renderer.render(spp=spp, seed=2)
        assert result.discarded_samples == 0 and np.all(np.isfinite(result.image))
        assert np.all(result.image[:4] == 1.0)     # above the face: nothing in the way
        if position[2] == 0:
            # Below: through 2 units of sigma_a = 4. Each sample's path crosses the box unabsorbed
            # with probability e^-8 (the tracking's estimate of an absorber is 0 or 1 per
            # sample), so of these 36 pixels' 144 samples three or more escape with probability
            # 2e-5; a ray the box test lost escapes every time (all 4 samples of its pixel).
            escaped = np.rint(result.image[5:, :, 0].sum() * spp)
            assert escaped <= 2, escaped


@pytest.mark.parametrize("method", ["null", "raymarch"])
def test_absorbing_fog_beside_a_grid_cloud_renders_as_without_it(device, method):
    # An absorbing homogeneous fog sphere under a sun, and beside it (in view, not between the fog
    # and the camera or the sun) a grid cloud that only absorbs (albedo 0); the background is
    # black. No path through the fog's pixels can gain or lose light by the cloud, so they must
    # render as with no cloud at all, where the kernel has no grid-media code. The cloud only
    # switches the grid-media code on, which once ran the grid lookup for the homogeneous fog
    # too (reading an unset voxel map): camera rays then crossed the fog as if it were empty.
    # Tolerance: 5 standard errors of the mean per-pixel difference over the fog's pixels.
    fog = {"name": "fog", "sigma_t": 2.0, "albedo": 0.5, "g": 0.3}
    cloud = {"name": "cloud", "type": "grid", "sigma_t": 3.0, "albedo": 0.0,
             "density": {"procedural": "noise_cloud", "resolution": [8, 8, 8], "seed": 1},
             "transform": {"scale": 1.2, "translate": [0.6, -0.6, -0.6]}}
    data = {"camera": camera(position=(0, 0, 6), look_at=(0, 0, 0), fov=40, resolution=(24, 24)),
            "media": [fog, cloud],
            "materials": [BOUNDARY],
            "shapes": [{"type": "sphere", "material": "boundary", "interior": "fog", "center": [-0.9, 0, 0],
                        "radius": 0.8},
                       {"type": "box", "material": "boundary", "interior": "cloud",
                        "transform": {"scale": 0.6, "translate": [1.2, 0, 0]}}],
            "lights": [{"type": "directional", "direction": [0, -1, -0.2], "irradiance": 10.0}],
            "render": {"max_depth": 16}}
    without = {**data, "media": [fog], "shapes": data["shapes"][:1]}
    images = []
    for scene_data in (data, without):
        scene = clrender.load_scene_dict(scene_data)
        renderer = clrender.Renderer(scene, device, volume_method=method)
        assert renderer.features["GRID_MEDIA"] == (len(scene.media) - 1) * {"null": 1, "raymarch": 2}[method]
        images.append(renderer.render(spp=32, seed=5))
    fog_pixels = images[1].aux["object_id"] == 0
    assert fog_pixels.sum() > 40 and np.all(images[0].aux["object_id"][fog_pixels] == 0)
    assert images[1].image[fog_pixels].mean() > 0.1    # the fog is lit
    for result in images:
        assert result.discarded_samples == 0
    for c in range(3):
        difference = images[0].image[..., c][fog_pixels] - images[1].image[..., c][fog_pixels]
        assert z_bound(difference, 0.0) < 5.0, (c, images[0].image[..., c][fog_pixels].mean(),
                                                images[1].image[..., c][fog_pixels].mean())
