"""Lights with closed-form answers: environment importance sampling, directional, point and spot
lights."""
import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender.arrays import build_scene_arrays
from clrender.render import render_params
from conftest import build_test_kernels, camera, delta_light_values, z_bound
from mitsuba_envmap import mitsuba_envmap_lookup

ALBEDO = 0.6


def floor_scene(lights, resolution=(24, 24), fov=20):
    """A small upward-facing diffuse square filling the view of a camera looking straight down."""
    return {
        "camera": camera(position=(0, 2, 0), look_at=(0, 0, 0), up=(0, 0, -1), fov=fov, resolution=resolution),
        "materials": [{"name": "floor", "type": "diffuse", "albedo": [ALBEDO] * 3}],
        "shapes": [{"type": "rectangle", "material": "floor", "transform": {"rotate": [-90, 0, 0]}}],
        "lights": lights,
        "render": {"max_depth": 4},
    }


def environment_image(height=16, width=32):
    """A smooth sky with a small very bright patch (a 'sun'), as a lat-long image."""
    v = (np.arange(height) + 0.5) / height
    image = np.zeros((height, width, 3), np.float32)
    image[...] = (0.2 + 0.8 * np.cos(v * np.pi).clip(0))[:, None, None] * np.array([0.6, 0.8, 1.0])
    image[4, 10] = [400.0, 300.0, 200.0]
    return image


def upper_hemisphere_irradiance(image):
    """Integral of L(w) cos(theta) over y > 0 for a piecewise-constant lat-long image, exactly:
    a texel row [theta0, theta1] contributes delta_phi * (sin^2 theta1 - sin^2 theta0) / 2."""
    height, width, _ = image.shape
    theta = np.linspace(0, np.pi, height + 1)
    upper = theta[1:] <= np.pi / 2 + 1e-12
    weight = (np.sin(theta[1:]) ** 2 - np.sin(theta[:-1]) ** 2) / 2 * (2 * np.pi / width)
    return np.einsum("hwc,h->c", image[upper], weight[upper])


# Sampling grids: the map's texels (its 32 columns), and cells of 4 x 4 texels (the grid of a
# map wider than arrays.ENV_SAMPLING_COLUMNS, here set to 8).
GRIDS = [None, 8]


def sampling_grid(monkeypatch, columns):
    if columns is not None:
        monkeypatch.setattr(clrender.arrays, "ENV_SAMPLING_COLUMNS", columns)


def bilinear_upper_hemisphere_irradiance(image, rotation, steps=1024):
    """Integral of L(w) cos(theta) over y > 0 for Mitsuba's lookup of `image` in the frame
    `rotation` turns, by the midpoint rule on a steps x 4 steps (theta, phi) grid (the lookup is
    continuous and piecewise bilinear: the rule's error is far below the test's noise)."""
    theta = (np.arange(steps) + 0.5) / steps * np.pi / 2
    phi = (np.arange(4 * steps) + 0.5) / (4 * steps) * 2 * np.pi
    sin_theta, cos_theta = np.sin(theta)[:, None], np.cos(theta)[:, None]
    world = np.stack(np.broadcast_arrays(sin_theta * np.sin(phi), cos_theta, -sin_theta * np.cos(phi)), axis=-1)
    radiance = mitsuba_envmap_lookup(image, world.reshape(-1, 3) @ rotation).reshape(steps, 4 * steps, 3)
    weight = (cos_theta * sin_theta) * (np.pi / 2 / steps) * (2 * np.pi / (4 * steps))
    return np.einsum("tpc,tp->c", radiance, np.broadcast_to(weight, radiance.shape[:2]))


# The environment image's lookups (docs/scene-format.md): constant texels, as is or turned, and
# Mitsuba's bilinear one in a tilted frame.
TILTED = {"rotate": [25, 70, 0]}
LOOKUPS = [("texel", None), ("texel", TILTED), ("mitsuba", TILTED)]
LOOKUP_IDS = ["texel", "texel turned", "mitsuba turned"]


def environment_light(lookup, transform):
    light = {"type": "environment", "file": "sky.exr", "lookup": lookup}
    return light if transform is None else {**light, "transform": transform}


@pytest.mark.parametrize("columns", GRIDS)
@pytest.mark.parametrize("lookup,transform", [LOOKUPS[0], LOOKUPS[2]], ids=[LOOKUP_IDS[0], LOOKUP_IDS[2]])
def test_environment_image_lighting_matches_the_integral(device, tmp_path, monkeypatch, columns, lookup, transform):
    # Mitsuba's bilinear radiance is not proportional to the sampled density (constant in each
    # cell): light and BSDF samples still sum, under MIS, to the integral.
    sampling_grid(monkeypatch, columns)
    image = environment_image()
    clrender.save_image(image, tmp_path / "sky.exr")
    scene = clrender.load_scene_dict(floor_scene([environment_light(lookup, transform)]), base_dir=tmp_path)
    result = clrender.Renderer(scene, device).render(spp=64, seed=4)
    assert result.discarded_samples == 0
    irradiance = (upper_hemisphere_irradiance(image) if lookup == "texel"
                  else bilinear_upper_hemisphere_irradiance(image, scene.environment.rotation))
    expected = ALBEDO / np.pi * irradiance
    for channel in range(3):
        assert z_bound(result.image[..., channel], expected[channel]) < 5.0


def reference_cells(image, lookup):
    """Luminance x sin(theta) of each cell of the environment's (u, v) square, from its
    definition: a texel's, or (Mitsuba's lookup) the mean of the four texels at a cell's corners,
    the cells between each two texel centres, the last column and the first included."""
    luminance = image @ np.array([0.2126, 0.7152, 0.0722])
    if lookup == "mitsuba":
        right = np.roll(luminance, -1, axis=1)
        luminance = (luminance[:-1] + right[:-1] + luminance[1:] + right[1:]) / 4
    return luminance * np.sin((np.arange(len(luminance)) + 0.5) / len(luminance) * np.pi)[:, None]


@pytest.mark.parametrize("columns", GRIDS)
@pytest.mark.parametrize("lookup,transform", LOOKUPS, ids=LOOKUP_IDS)
def test_environment_sampling_follows_its_pdf(context, queue, tmp_path, monkeypatch, columns, lookup, transform):
    # Chi-square of the sampled cells of the (u, v) square (kernels/lights.h) in the image's
    # frame against the tabulated probabilities (a grid cell's, uniform over its cells in (u, v)),
    # the returned solid-angle pdf against the table at every sample, and the radiance the
    # texel's or Mitsuba's lookup (tests/mitsuba_envmap.py, checked against Mitsuba).
    sampling_grid(monkeypatch, columns)
    # 40 columns on the texels' grid: the searches' blocks of 16 CDF entries (kernels/lights.h)
    # end in a part-filled one, as the rows do (15 or 16 in one block)
    image = environment_image(width=40 if columns is None else 32)
    clrender.save_image(image, tmp_path / "sky.exr")
    scene = clrender.load_scene_dict(floor_scene([environment_light(lookup, transform)]), base_dir=tmp_path)
    arrays = build_scene_arrays(scene)
    params = render_params(scene, arrays, 0, 1, 1, 1, 0)
    program = build_test_kernels(context, ENVIRONMENT=2)
    count = 200_000
    mf = cl.mem_flags
    buffers = [cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=x)
               for x in (params, arrays.env_texels, arrays.env_cdf)]
    out, radiance, looked_up = (np.empty((count, 4), np.float32) for _ in range(3))
    out_buffers = [cl.Buffer(context, mf.WRITE_ONLY, x.nbytes) for x in (out, radiance, looked_up)]
    program.sample_environment(queue, (count,), None, *buffers, np.uint32(9), *out_buffers)
    for host, buffer in zip((out, radiance, looked_up), out_buffers):
        cl.enqueue_copy(queue, host, buffer)

    weights = reference_cells(image, lookup)
    height, width = weights.shape
    d = out[:, :3].astype(float)
    local = d @ scene.environment.rotation   # the image's frame: its axes' components
    u = np.arctan2(local[:, 0], -local[:, 2]) / (2 * np.pi) + (0.5 if lookup == "texel" else -0.5 / width)
    u = (u - np.floor(u)) * width
    v = np.arccos(np.clip(local[:, 1], -1, 1)) / np.pi * height
    cell = np.clip(v.astype(int), 0, height - 1) * width + np.clip(u.astype(int), 0, width - 1)
    grid_columns, grid_rows = clrender.arrays.environment_sampling_grid(width, height)
    assert (grid_columns, grid_rows) == ((width, height) if columns is None else (8, height // 4 if height % 2 == 0 else height))
    fy, fx = height // grid_rows, width // grid_columns
    grid = weights.reshape(grid_rows, fy, grid_columns, fx).sum(axis=(1, 3))
    pmf = np.repeat(np.repeat(grid, fy, axis=0), fx, axis=1).ravel() / (fx * fy) / weights.sum()
    observed = np.bincount(cell, minlength=height * width)
    expected = pmf * count
    big = expected > 20
    chi2 = np.sum((observed[big] - expected[big]) ** 2 / expected[big])
    dof = big.sum() - 1
    assert chi2 < dof + 5 * np.sqrt(2 * dof), (chi2, dof)  # chi-square mean dof, sd sqrt(2 dof)
    # pdf_w * (2 pi^2 sin theta) is the (u, v) density, which equals pmf * cell count. At a pole
    # (sin theta rounded to 0: a cell's edge, which a coarse grid's top cell reaches at times) the
    # solid-angle density is infinite and the kernel says 0: such a light sample counts nothing.
    # A turned direction is rounded to float32 on its way out and back into the image's frame:
    # within 1e-4 of a cell's edge, and near the poles, where theta = acos(y) magnifies y's
    # rounding, the kernel may see another cell or sin(theta) than this test (a rounding of the
    # direction, in both ways the same for the kernel's sample and its pdf). Those are left out.
    at_pole = out[:, 3] == 0
    assert at_pole.mean() < 1e-4 and np.all(np.abs(local[at_pole, 1]) > 1 - 1e-6)
    settled = (np.abs(local[:, 1]) < 1 - 1e-4) & (np.abs(u - np.round(u)) > 1e-4) & (np.abs(v - np.round(v)) > 1e-4)
    assert settled.mean() > 0.99, settled.mean()
    pdf_uv = out[:, 3] * 2 * np.pi ** 2 * np.sqrt(np.maximum(0, 1 - local[:, 1] ** 2))
    np.testing.assert_allclose(pdf_uv[settled], pmf[cell[settled]] * height * width, rtol=2e-3)
    # The sampler's pdf and radiance come from the (u, v) it drew; a BSDF sample along the same
    # direction finds them again from the direction (the MIS weights need the same pdf).
    np.testing.assert_allclose(looked_up[settled, 3], out[settled, 3], rtol=1e-4)
    for seen in (radiance, looked_up):
        if lookup == "texel":
            np.testing.assert_allclose(seen[settled, :3], image.reshape(-1, 3)[cell[settled]], rtol=1e-6)
        else:   # continuous: a rounding of the direction moves it by 1e-6 of the sun's 400
            np.testing.assert_allclose(seen[:, :3], mitsuba_envmap_lookup(image, local), rtol=1e-4, atol=1e-3)


def test_environment_tables_are_the_cdfs_of_each_row_and_of_the_rows():
    """The tables built a band of rows at a time (here 3 bands) are the marginal CDF of the rows
    and each row's conditional CDF of luminance x sin(theta); a black row is uniform."""
    from clrender.arrays import LUMINANCE, _cdf, _environment_tables
    from clrender.layout import ENV_CDF_BLOCK

    height, width = 5000, 500
    image = np.random.default_rng(6).uniform(0, 2, (height, width, 3)).astype(np.float32)
    image[[0, 2500, 4999]] = 0.0
    texels, cdf, mean = _environment_tables(image)
    weights = (image @ LUMINANCE) * np.sin((np.arange(height) + 0.5) / height * np.pi)[:, None]
    assert cdf[:2].tolist() == [width, height]   # the sampling grid: the texels (500 columns)
    np.testing.assert_array_equal(cdf[2:height + 3], _cdf(weights.sum(axis=1)))
    end = height + 3 + height * (width + 1)
    rows = cdf[height + 3:end].reshape(height, width + 1)
    for row in (0, 1, 2097, 2500, 4998, 4999):
        np.testing.assert_array_equal(rows[row], _cdf(weights[row]))
    # then every 16th entry (layout.ENV_CDF_BLOCK) of the marginal, 313 of its 5000
    # rows, and of each row, 32 of its 500 columns: what the kernel's search looks through first
    assert ENV_CDF_BLOCK == 16 and len(cdf) == end + 313 + height * 32
    np.testing.assert_array_equal(cdf[end:end + 313], cdf[2:height + 2:16])
    np.testing.assert_array_equal(cdf[end + 313:].reshape(height, 32), rows[:, :width:16])
    np.testing.assert_array_equal(texels[:, :3], image.reshape(-1, 3))
    assert mean == pytest.approx((image.mean(axis=2, dtype=float) * np.sin((np.arange(height) + 0.5) / height
                                                                          * np.pi)[:, None]).mean()
                                 / np.sin((np.arange(height) + 0.5) / height * np.pi).mean(), rel=1e-12)


def test_a_wide_maps_sampling_grid_sums_cells_of_texels():
    """A 4096 x 2048 map is sampled on a 1024 x 512 grid of 4 x 4 texels, whose tables are the
    CDFs of the cells' sums; odd numbers of columns keep their texels, odd rows keep their rows."""
    from clrender.arrays import LUMINANCE, _cdf, _environment_tables, environment_sampling_grid

    assert environment_sampling_grid(4096, 2048) == (1024, 512)
    assert environment_sampling_grid(2048, 1024) == (1024, 512)
    assert environment_sampling_grid(3000, 1501) == (750, 1501)   # odd rows: cells of 4 x 1
    assert environment_sampling_grid(2048, 1023) == (1024, 1023)   # Mitsuba's lookup of 2048 x 1024
    assert environment_sampling_grid(3001, 1500) == (3001, 1500)
    assert environment_sampling_grid(1024, 512) == (1024, 512)
    height, width = 2048, 4096
    image = np.random.default_rng(7).uniform(0, 2, (height, width, 3)).astype(np.float32)
    texels, cdf, mean = _environment_tables(image)
    weights = (image @ LUMINANCE) * np.sin((np.arange(height) + 0.5) / height * np.pi)[:, None]
    cells = weights.reshape(512, 4, 1024, 4).sum(axis=(1, 3))
    assert cdf[:2].tolist() == [1024, 512] and len(cdf) == 2 + 513 + 512 * 1025 + 512 // 16 + 512 * 1024 // 16
    np.testing.assert_allclose(cdf[2:515], _cdf(cells.sum(axis=1)), atol=1e-7)
    rows = cdf[515:515 + 512 * 1025].reshape(512, 1025)
    for row in (0, 255, 511):
        np.testing.assert_allclose(rows[row], _cdf(cells[row]), atol=1e-7)


def test_directional_light_gives_exact_cosine_irradiance(device):
    direction = np.array([0.3, -1.0, 0.2])
    scene = clrender.load_scene_dict(floor_scene([{"type": "directional", "direction": direction.tolist(),
                                                   "irradiance": [2.0, 3.0, 4.0]}]))
    result = clrender.Renderer(scene, device).render(spp=4, seed=1)
    cosine = -direction[1] / np.linalg.norm(direction)
    expected = ALBEDO / np.pi * np.array([2.0, 3.0, 4.0]) * cosine
    # No noise: the light is a delta and no other light exists.
    np.testing.assert_allclose(result.image, np.broadcast_to(expected, result.image.shape), rtol=1e-5)


def test_point_light_inverse_square(device):
    intensity, height = 5.0, 0.75
    scene = clrender.load_scene_dict(floor_scene([{"type": "point", "position": [0, height, 0],
                                                   "intensity": intensity}], resolution=(33, 33), fov=10))
    result = clrender.Renderer(scene, device).render(spp=4, seed=1)
    centre = result.image[16, 16]
    expected = ALBEDO / np.pi * intensity / height ** 2
    # Within the centre pixel the distance to the light varies by < 1e-4 relative.
    np.testing.assert_allclose(centre, expected, rtol=2e-4)
    assert result.image[0, 0, 0] < centre[0]


def spot_falloff(theta, cutoff, beam):
    """Mitsuba's spot falloff at angle theta (degrees) from the axis, from its definition."""
    beam = min(beam, cutoff)
    ramp = (cutoff - theta) / (cutoff - beam) if beam < cutoff else 1.0
    return np.where(theta < cutoff, np.where(theta <= beam, 1.0, ramp), 0.0)


@pytest.mark.parametrize("cutoff,beam", [(20, 15), (60, 10), (180, 135), (30, 45), (40, 40)])
def test_spot_light_falls_off_as_mitsubas(context, queue, cutoff, beam):
    # Points on a unit circle around the light at angles to its axis (a tilted one), with the
    # intensity's inverse square and the falloff: 1 within the beam width, linear in the angle
    # to 0 at the cutoff.
    position, axis = np.array([0.2, 1.0, -0.3]), np.array([0.3, -1.0, 0.1])
    axis /= np.linalg.norm(axis)
    light = {"type": "spot", "position": position.tolist(), "direction": axis.tolist(), "intensity": [2, 3, 4],
             "cutoff_angle": cutoff, "beam_width": beam}
    # Off the cutoff itself, where the falloff jumps to 0 when the beam is as wide (rounding
    # decides there); nearer 180 degrees than 0.5, float32 cosines round to -1 (in Mitsuba too).
    theta = np.concatenate([[0.0], np.arange(0.25, 179.5, 0.5), [beam - 0.01, beam + 0.01, cutoff - 0.01, cutoff + 0.01]])
    theta = theta[theta <= 179.5]
    side = np.cross(axis, [0, 0, 1])
    side /= np.linalg.norm(side)
    distance = 1.7
    points = position + distance * (np.cos(np.radians(theta))[:, None] * axis + np.sin(np.radians(theta))[:, None] * side)
    radiance, dist = delta_light_values(context, queue, clrender.load_scene_dict(floor_scene([light])), points)
    np.testing.assert_allclose(dist, distance, rtol=1e-5)
    falloff = radiance / (np.array([2, 3, 4]) / distance ** 2)
    # The kernel's angle from a float32 cosine: within 1e-4 degrees on the ramp (at least 2
    # degrees from the axis), whose slope is at most 1/5 per degree here.
    np.testing.assert_allclose(falloff, np.repeat(spot_falloff(theta, cutoff, beam)[:, None], 3, axis=1), atol=1e-4)


@pytest.mark.parametrize("cutoff,beam", [(20, 15), (60, 10), (180, 135), (30, 45)])
def test_spot_light_power_is_its_integral(cutoff, beam):
    from scipy.integrate import quad

    from clrender.arrays import spot_solid_angle
    from clrender.scene import Light

    light = Light("spot", np.ones(3), np.zeros(3), np.array([0, 0, 1.0]), cutoff_angle=cutoff, beam_width=beam)
    integral = 2 * np.pi * quad(lambda t: float(spot_falloff(np.degrees(t), cutoff, beam)) * np.sin(t), 0, np.pi,
                                points=[np.radians(min(beam, cutoff)), np.radians(cutoff)])[0]
    assert np.isclose(spot_solid_angle(light), integral, rtol=1e-9)


def test_spot_light_lights_the_floor_as_a_point_light_within_its_beam(device):
    # Straight down from 0.75 above the floor, with a beam wider than the view: the point
    # light's image; with its cutoff inside the view, the centre as bright, the corners black.
    # Both in the megakernel (CPUs would take the point light's paths in packets, which round
    # differently), so that equal light gives equal bits.
    def render(light):
        scene = clrender.load_scene_dict(floor_scene([light], resolution=(33, 33), fov=10))
        return clrender.Renderer(scene, device, packets=False).render(spp=4, seed=1).image

    point = render({"type": "point", "position": [0, 0.75, 0], "intensity": 5.0})
    spot = {"type": "spot", "position": [0, 0.75, 0], "direction": [0, -1, 0], "intensity": 5.0}
    assert np.array_equal(render({**spot, "cutoff_angle": 60, "beam_width": 50}), point)
    narrow = render({**spot, "cutoff_angle": 4, "beam_width": 2})
    assert np.array_equal(narrow[16, 16], point[16, 16])
    assert np.all(narrow[0, 0] == 0) and 0 < narrow[16, 20, 0] < point[16, 20, 0]   # 3.2 degrees off the axis
