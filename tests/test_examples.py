"""Every example scene loads and renders finite images; the furnace scene vanishes."""
import glob
import os

import numpy as np
import pytest

import clrender
from conftest import z_bound

SCENES = sorted(glob.glob(os.path.join(os.path.dirname(__file__), "..", "scenes", "*.json")))


@pytest.mark.parametrize("path", SCENES, ids=lambda p: os.path.basename(p))
def test_example_scene_renders(device, path):
    scene = clrender.load_scene(path)
    width, height = scene.camera.resolution
    scene.camera.resolution = (24, max(1, round(24 * height / width)))
    result = clrender.Renderer(scene, device).render(spp=2, max_depth=min(scene.render.max_depth, 16))
    assert result.discarded_samples == 0
    assert np.all(np.isfinite(result.image)) and result.image.max() > 0


def test_furnace_scene_vanishes(device):
    # Diffuse (albedo 1), smooth glass, rough glass and a white scattering medium in a uniform
    # environment of radiance 0.5: every pixel estimates 0.5.
    scene = clrender.load_scene(os.path.join(os.path.dirname(__file__), "..", "scenes", "furnace.json"))
    scene.camera.resolution = (80, 24)
    image = clrender.Renderer(scene, device).render(spp=32, seed=6).image
    # The background is exactly 0.5; the pixels covering objects are noisy estimates of 0.5,
    # tested together within 5 standard errors.
    objects = image[..., 0] != 0.5
    assert objects.sum() > 200
    for c in range(3):
        assert z_bound(image[..., c][objects], 0.5) < 5.0
