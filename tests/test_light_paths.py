"""Light paths (clrender/light_paths.py, kernels/light_paths.h, .cl): the caustics light -> delta+ ->
non-delta -> ... -> camera traced from the lights, which the path tracer leaves out.

The image with light paths is the path tracer's alone in expectation (per seed, the difference
of the two images' means, over the whole image and where the caustic lies, within 5 standard
errors; fixed seeds), with less noise where the caustic is; the same bits however the samples
are split into passes and tiles; the records' splatting conserves their weight. About 60 s on 2
cores.
"""
import numpy as np
import pytest

import clrender
from clrender import filters, light_paths
from clrender.features import scene_features
from clrender.scene import Filter
from conftest import assert_splits_keep_the_bits, z_bound


def ball_on_a_floor(light_paths_on=True, resolution=24, **camera):
    """A glass ball on a diffuse floor, lit from the side by a small bright square: its caustic
    lies on the floor beyond the ball, seen from above."""
    return clrender.load_scene_dict({
        "camera": {"position": [-0.3, 4, 0.001], "look_at": [-0.3, 0, 0], "up": [0, 0, -1], "fov": 40,
                   "resolution": [resolution, resolution], **camera},
        "render": {"max_depth": 6, "light_paths": light_paths_on},
        "materials": [{"name": "floor", "type": "diffuse", "albedo": [0.8, 0.8, 0.8]},
                      {"name": "lamp", "type": "emissive", "radiance": [100, 100, 100]},
                      {"name": "glass", "type": "dielectric", "ior": 1.5}],
        "shapes": [{"name": "floor", "type": "rectangle", "material": "floor",
                    "transform": {"scale": [3, 3, 1], "rotate": [-90, 0, 0]}},
                   {"name": "ball", "type": "sphere", "material": "glass", "center": [0, 0.5, 0], "radius": 0.5},
                   {"name": "lamp", "type": "rectangle", "material": "lamp",
                    "transform": {"scale": [0.08, 0.08, 1], "rotate": [0, -90, 0], "translate": [1.5, 1.5, 0]}}]})


def renders(scene, device, packets, seeds, spp=32):
    renderer = clrender.Renderer(scene, device, packets=packets)
    return renderer, np.stack([renderer.render(spp=spp, seed=s).image for s in seeds]).astype(float)


@pytest.mark.parametrize("packets", [False, True])
def test_light_paths_keep_the_image_and_lower_the_caustics_noise(device, packets):
    seeds = range(1, 17)
    renderer, traced = renders(ball_on_a_floor(True), device, packets, seeds)
    assert renderer.light_path_every == light_paths.EVERY
    _, alone = renders(ball_on_a_floor(False), device, packets, seeds)
    assert z_bound(traced.mean(axis=(1, 2, 3)) - alone.mean(axis=(1, 2, 3)), 0.0) < 5
    # The caustic: the floor beyond the ball, away from the lamp.
    caustic = (slice(9, 16), slice(4, 10))
    region = [images[:, caustic[0], caustic[1]] for images in (traced, alone)]
    assert region[1].mean() > 3 * alone.mean()
    assert z_bound(region[0].mean(axis=(1, 2, 3)) - region[1].mean(axis=(1, 2, 3)), 0.0) < 5
    assert region[0].var(axis=0, ddof=1).mean() < 0.5 * region[1].var(axis=0, ddof=1).mean()


def test_the_split_into_passes_and_tiles_keeps_the_bits(device):
    assert_splits_keep_the_bits(clrender.Renderer(ball_on_a_floor(True, resolution=16), device))


@pytest.mark.parametrize("change,expected", [
    ({}, True),
    ({"light_paths": False}, False),
    ({"integrator": "direct"}, False),
    ({"hide_emitters": True}, False),
    ({"aperture_radius": 0.1, "focus_distance": 4.0}, False),
])
def test_where_light_paths_apply(change, expected):
    scene = ball_on_a_floor(True)
    for key, value in change.items():
        target = scene.camera if key in ("aperture_radius", "focus_distance") else scene.render
        setattr(target, key, value)
    assert light_paths.applies(scene, scene_features(scene)) == expected


def test_no_delta_surface_or_no_plain_emitting_triangle_means_no_light_paths():
    scene = ball_on_a_floor(True)
    scene.materials[2].type, scene.materials[2].roughness = "diffuse", 0.0
    assert not light_paths.applies(scene, scene_features(scene))


@pytest.mark.parametrize("camera_filter", [Filter("box"), Filter("tent", radius=1.0), Filter("gaussian", stddev=0.5)])
def test_splatting_a_record_conserves_its_weight(camera_filter):
    records = np.zeros((3, light_paths.RECORD_FLOATS), np.float32)
    records[0, [0, 1, 4, 5, 6]] = (8.3, 7.6, 1.0, 2.0, 4.0)       # inside, away from the edges
    records[1, [0, 1, 4, 5, 6]] = (0.2, 7.5, 1.0, 1.0, 1.0)       # at the left edge
    records[2, [0, 1, 4, 5, 6]] = (np.nan, 3.0, 1.0, 1.0, 1.0)    # not finite: left out
    sums = light_paths.splat(records[:1], camera_filter, 16, 16).reshape(16, 16, 3) / light_paths.FIXED_POINT
    # Each pixel gets the record's weight times its filter at the record, normalised to integrate
    # to 1 (the filtered measurement a pixel estimates, as splatting's normalised sums do).
    mass = filters.cumulative(camera_filter, filters.radius(camera_filter))
    centres = np.arange(16) + 0.5
    weights = np.outer(filters.evaluate(camera_filter, centres - 7.6), filters.evaluate(camera_filter, centres - 8.3))
    np.testing.assert_allclose(sums, weights[:, :, None] / mass**2 * [1, 2, 4], rtol=1e-5, atol=1e-6)
    if camera_filter.type != "gaussian":   # the box and the tent of radius 1 sum to 1 over pixels
        np.testing.assert_allclose(sums.sum(axis=(0, 1)), [1, 2, 4], rtol=1e-5)
    edge = light_paths.splat(records[1:], camera_filter, 16, 16).sum(axis=0) / light_paths.FIXED_POINT
    assert np.all(edge <= 1 + 1e-6) and (camera_filter.type == "box" or np.all(edge < 1))
    # The image divides by the filter's mass inside it: records spread evenly over the image, 16
    # to a pixel, each of weight 1, make an image of 1 to its edges.
    positions = (np.arange(16)[:, None] + (np.arange(4) + 0.5) / 4).ravel()
    x, y = np.meshgrid(positions, positions)
    field = np.zeros((x.size, light_paths.RECORD_FLOATS), np.float32)
    field[:, 0], field[:, 1], field[:, 4:7] = x.ravel(), y.ravel(), 1.0
    image = light_paths.image(light_paths.splat(field, camera_filter, 16, 16), x.size, camera_filter, 16, 16)
    np.testing.assert_allclose(image, 1.0, rtol=0.02)
