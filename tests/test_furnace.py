"""Furnace tests: scenes whose pixel values are known exactly.

Tolerances: pixels of these scenes are independent estimates of the same expectation, so the
standard error of their mean follows from their spread; we require |mean - expected| < 5 SE
(fixed seeds, so the outcome is deterministic; 5 SE would fail by chance ~1 in 1.7 million).
"""
import numpy as np
import pytest

import clrender
from conftest import camera, sphere, z_bound


def sphere_in_environment(albedo, resolution=(32, 32), analytic=True):
    return clrender.load_scene_dict({
        "camera": camera(resolution=resolution, fov=30),
        "materials": [{"name": "m", "type": "diffuse", "albedo": [albedo] * 3}],
        "shapes": [sphere(analytic, material="m", radius=1.0)],
        "lights": [{"type": "environment", "radiance": 1.0}],
        "render": {"max_depth": 16, "rr_depth": 3},
    })


@pytest.mark.parametrize("analytic", [True, False], ids=["sphere", "icosphere"])
@pytest.mark.parametrize("albedo", [1.0, 0.5])
def test_convex_diffuse_sphere_in_uniform_environment(device, albedo, analytic):
    # A convex lossless object reflects exactly the uniform radiance around it: the pixel equals
    # coverage * albedo + (1 - coverage) * 1. Coverage comes from an emission-only render with
    # the same seed, whose camera rays are identical.
    scene = sphere_in_environment(albedo, analytic=analytic)
    renderer = clrender.Renderer(scene, device)
    coverage_image = renderer.render(spp=64, max_depth=1, seed=3).image
    result = renderer.render(spp=64, seed=3)
    assert result.discarded_samples == 0
    background = coverage_image == 1.0
    assert np.all(result.image[background] == 1.0)
    expected = coverage_image + (1.0 - coverage_image) * albedo
    covered = coverage_image[..., 0] == 0.0
    assert covered.sum() > 200
    assert z_bound(result.image[covered], albedo) < 5.0
    assert z_bound(result.image - expected, 0.0) < 5.0


@pytest.mark.parametrize("analytic", [True, False], ids=["sphere", "icosphere"])
@pytest.mark.parametrize("albedo,max_depth,rr_depth", [(0.5, 6, 100), (0.5, 6, 2), (0.8, 40, 3)])
def test_closed_emissive_enclosure_sums_the_geometric_series(device, albedo, max_depth, rr_depth, analytic):
    # Camera inside a closed emitter of radiance E and albedo a: every path vertex sees E, so
    # L = E * sum_{k < max_depth} a^k, exactly, whatever the geometry. Roulette must not bias it.
    emission = 0.25
    scene = clrender.load_scene_dict({
        "camera": camera(position=(0, 0, 0.2), look_at=(0, 0, -1), fov=60),
        "materials": [{"name": "wall", "type": "diffuse", "albedo": [albedo] * 3,
                       "emission": [emission] * 3}],
        "shapes": [sphere(analytic, subdivisions=2, material="wall", radius=1.0, flip_normals=True)],
        "render": {"max_depth": max_depth, "rr_depth": rr_depth},
    })
    result = clrender.Renderer(scene, device).render(spp=32, seed=11)
    assert result.discarded_samples == 0
    expected = emission * sum(albedo ** k for k in range(max_depth))
    assert z_bound(result.image, expected) < 5.0
