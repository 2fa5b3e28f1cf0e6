"""The thin-lens camera (kernels/camera.h, through_lens): its rays start uniformly on the
aperture and meet where the pinhole ray meets the plane in focus; its images keep the
determinism of the pinhole's. Its rays against Mitsuba's thinlens: tests/test_mitsuba_parity.py."""
import numpy as np

import clrender
from conftest import camera, camera_rays

LENS = {**camera(position=(0.5, 1, 5), look_at=(0, 0.2, 0), resolution=(40, 24)), "aperture_radius": 0.3,
        "focus_distance": 4.0}


def scene_of(camera_fields):
    return clrender.load_scene_dict({"camera": camera_fields, "materials": [{"name": "m", "type": "diffuse"}],
                                     "shapes": [{"type": "sphere", "material": "m"}],
                                     "lights": [{"type": "directional", "direction": [-1, -1, -1], "irradiance": 2}]})


def test_rays_start_uniformly_on_the_aperture(context, queue):
    scene = scene_of(LENS)
    rng = np.random.default_rng(4)
    count, rings, sectors = 160_000, 20, 8
    samples = np.column_stack([np.full(count, 13.3), np.full(count, 7.8), rng.random((count, 2))])
    origins, _ = camera_rays(context, queue, scene, samples)
    forward, right, up = scene.camera.basis()
    offset = (origins - scene.camera.position) / LENS["aperture_radius"]
    assert np.allclose(offset @ forward, 0, atol=1e-5)   # float32 positions near 5, over the radius 0.3
    x, y = offset @ (right / np.linalg.norm(right)), offset @ (up / np.linalg.norm(up))
    r2 = x * x + y * y
    assert r2.max() <= 1 + 1e-5
    # Uniform on the disk: r^2 and the angle uniform; chi-square below dof + 5 sqrt(2 dof).
    ring = np.minimum((r2 * rings).astype(int), rings - 1)
    sector = np.minimum(((np.arctan2(y, x) / (2 * np.pi)) % 1 * sectors).astype(int), sectors - 1)
    observed = np.bincount(ring * sectors + sector, minlength=rings * sectors)
    expected = count / (rings * sectors)
    dof = rings * sectors - 1
    assert np.sum((observed - expected) ** 2 / expected) < dof + 5 * np.sqrt(2 * dof)


def test_rays_meet_on_the_plane_in_focus(context, queue):
    scene = scene_of(LENS)
    forward = scene.camera.basis()[0]
    rng = np.random.default_rng(5)
    for position in ([0.0, 0.0], [13.3, 7.8], [40.0, 24.0], [39.5, 0.5]):
        samples = np.column_stack([np.tile(position, (64, 1)), rng.random((64, 2))])
        origins, directions = camera_rays(context, queue, scene, samples)
        assert np.allclose(np.linalg.norm(directions, axis=1), 1, atol=1e-6)
        pinhole = scene.camera.pixel_directions(*position)
        focus = scene.camera.position + pinhole * LENS["focus_distance"] / (pinhole @ forward)
        # Where each ray crosses the plane in focus: the pinhole ray's point, to float rounding.
        t = ((focus - origins) @ forward) / (directions @ forward)
        assert np.allclose(origins + t[:, None] * directions, focus, atol=2e-5), position


def test_a_pinhole_takes_no_lens_numbers_and_a_lens_keeps_determinism(device):
    # The lens draws the path's second dimension only when there is a lens: pinhole images are
    # those of the code before it (bit for bit: tests/test_determinism.py's reference renders);
    # a lens image is the same however its samples are split.
    scene = scene_of(LENS)
    renderer = clrender.Renderer(scene, device)
    whole = renderer.render(spp=6, seed=3)
    assert np.array_equal(whole.image, renderer.render(spp=6, seed=3, samples_per_pass=1).image)
    sharp = clrender.Renderer(scene_of({**LENS, "aperture_radius": 0}), device).render(spp=6, seed=3)
    assert not np.array_equal(whole.image, sharp.image)
