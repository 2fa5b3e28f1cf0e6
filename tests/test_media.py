"""Homogeneous media against closed forms: transmittance, furnace, pure absorption.

Tolerances: |mean - expected| < 5 standard errors, with the standard error estimated from the
spread of independent pixel estimates (fixed seeds, so the outcome is deterministic).
"""
import numpy as np
import pytest

import clrender
from clrender import meshes
from clrender.bvh import intersect_brute_force
from clrender.features import scene_features
from conftest import camera, sphere, z_bound

BOUNDARY = {"name": "boundary", "type": "interface"}


def medium_scene(medium, shape, camera_args=None, lights=None, render=None):
    return {
        "camera": camera(**(camera_args or {})),
        "media": [dict(name="m", **medium)],
        "materials": [BOUNDARY],
        "shapes": [dict(material="boundary", interior="m", **shape)],
        "lights": lights if lights is not None else [{"type": "environment", "radiance": 1.0}],
        "render": render or {"max_depth": 64, "rr_depth": 5},
    }


SLAB = {"type": "box", "transform": {"scale": [3, 3, 0.25]}}  # thickness 0.5 along z


@pytest.mark.parametrize("spectral_mis", [True, False])
def test_slab_transmittance_per_channel(device, spectral_mis):
    # With max depth 1 no scattering vertex is allowed, so a pixel estimates exactly the
    # transmittance exp(-sigma_t d) of the slab in front of a uniform background of radiance 1.
    sigma_a, sigma_s = np.array([0.2, 1.0, 3.0]), np.array([1.0, 0.5, 0.5])
    scene = clrender.load_scene_dict(medium_scene(
        {"sigma_a": sigma_a.tolist(), "sigma_s": sigma_s.tolist()}, SLAB,
        camera_args={"fov": 5, "resolution": (32, 32)}, render={"max_depth": 1}))
    renderer = clrender.Renderer(scene, device, spectral_mis=spectral_mis)
    result = renderer.render(spp=128, seed=21)
    assert result.discarded_samples == 0
    expected = np.exp(-(sigma_a + sigma_s) * 0.5)
    # The view is nearly perpendicular: path lengths exceed 0.5 by < 0.1% at fov 5 degrees.
    for c in range(3):
        assert z_bound(result.image[..., c], expected[c]) < 5.0, (c, result.image[..., c].mean(), expected[c])


@pytest.mark.parametrize("g", [0.0, 0.3, -0.6])
def test_single_scattering_from_a_slab_lit_by_the_sun(device, g):
    # Camera and a directional light both look straight down on a slab of thickness d. With max
    # depth 2 a pixel is single scattering only, reached solely by next-event estimation (the
    # light is a delta), at scattering angle pi:
    #   L = sigma_s p_HG(-1) E (1 - exp(-2 sigma_t d)) / (2 sigma_t).
    # It checks distance sampling weights, the phase function and shadow-ray transmittance.
    thickness, irradiance = 0.6, 2.0
    sigma_a, sigma_s = np.array([0.3, 0.1, 1.0]), np.array([1.5, 0.6, 0.4])
    data = medium_scene({"sigma_a": sigma_a.tolist(), "sigma_s": sigma_s.tolist(), "g": g},
                        {"type": "box", "transform": {"scale": [6, thickness / 2, 6]}},
                        camera_args={"position": (0, 3, 0), "look_at": (0, 0, 0), "up": (0, 0, -1),
                                     "fov": 4, "resolution": (32, 32)},
                        lights=[{"type": "directional", "direction": [0, -1, 0], "irradiance": irradiance}],
                        render={"max_depth": 2})
    result = clrender.Renderer(clrender.load_scene_dict(data), device).render(spp=64, seed=17)
    sigma_t = sigma_a + sigma_s
    phase_backward = (1 - g * g) / (4 * np.pi * (1 + g) ** 3)
    expected = sigma_s * phase_backward * irradiance * (1 - np.exp(-2 * sigma_t * thickness)) / (2 * sigma_t)
    assert result.discarded_samples == 0
    for c in range(3):
        assert z_bound(result.image[..., c], expected[c]) < 5.0, (c, result.image[..., c].mean(), expected[c])


# g = +-0.99999999 rounds to +-1 in float32, where the phase density is 0 / 0 at its peak (and a
# NaN pdf silently zeroes MIS weights).
@pytest.mark.parametrize("g", [-0.9, 0.0, 0.9, 0.99999999, -0.99999999])
def test_scattering_sphere_in_furnace_vanishes(device, g):
    scene = clrender.load_scene_dict(medium_scene(
        {"sigma_t": [2.0, 1.0, 0.5], "albedo": 1.0, "g": g},
        {"type": "sphere", "radius": 1.0},
        camera_args={"resolution": (16, 16), "fov": 25}, render={"max_depth": 1000, "rr_depth": 5}))
    assert scene_features(scene)["MEDIA"] == 1
    result = clrender.Renderer(scene, device).render(spp=32, seed=5)
    assert result.discarded_samples == 0
    for c in range(3):
        assert z_bound(result.image[..., c], 1.0) < 5.0


@pytest.mark.parametrize("boundary", [BOUNDARY, {"name": "boundary", "type": "dielectric", "ior": 1.5},
                                      {"name": "boundary", "type": "dielectric", "ior": 1.5, "roughness": 0.4}],
                         ids=["interface", "glass", "rough glass"])
def test_a_medium_without_light_samples_vanishes_in_a_furnace(device, boundary):
    # sample_emitters false: the environment is found by phase (and BSDF) sampling alone, which
    # must then count with full weight (an MIS weight without its light-sample partner would
    # darken the sphere).
    data = medium_scene({"sigma_t": [2.0, 1.0, 0.5], "albedo": 1.0, "g": 0.6, "sample_emitters": False},
                        {"type": "sphere", "radius": 1.0}, camera_args={"resolution": (16, 16), "fov": 25},
                        render={"max_depth": 1000, "rr_depth": 5})
    data["materials"] = [boundary]
    result = clrender.Renderer(clrender.load_scene_dict(data), device).render(spp=32, seed=5)
    assert result.discarded_samples == 0
    for c in range(3):
        assert z_bound(result.image[..., c], 1.0) < 5.0


def test_a_medium_without_light_samples_makes_none(device):
    # The sunlit slab of test_single_scattering_from_a_slab_lit_by_the_sun: a delta light, which
    # only light samples reach. Without them the slab is black; with them it is not.
    data = medium_scene({"sigma_t": 1.5, "albedo": 0.8}, {"type": "box", "transform": {"scale": [6, 0.3, 6]}},
                        camera_args={"position": (0, 3, 0), "look_at": (0, 0, 0), "up": (0, 0, -1), "fov": 4,
                                     "resolution": (8, 8)},
                        lights=[{"type": "directional", "direction": [0, -1, 0], "irradiance": 2.0}],
                        render={"max_depth": 8})
    lit = clrender.Renderer(clrender.load_scene_dict(data), device).render(spp=8, seed=1).image
    data["media"][0]["sample_emitters"] = False
    dark = clrender.Renderer(clrender.load_scene_dict(data), device).render(spp=8, seed=1).image
    assert lit.min() > 0 and np.all(dark == 0)


def subpixel_rays(scene, samples_per_axis):
    """Camera rays through a regular sub-pixel grid: unit directions (H, W, samples, 3)."""
    width, height = scene.camera.resolution
    offsets = (np.arange(samples_per_axis) + 0.5) / samples_per_axis
    jx, jy = np.meshgrid(offsets, offsets)
    px, py = np.meshgrid(np.arange(width), np.arange(height))
    return scene.camera.pixel_directions(px[..., None] + jx.ravel(), py[..., None] + jy.ravel())


def chord_lengths(scene, samples_per_axis=8, camera_inside=False):
    """Per pixel and sub-pixel ray, the path length inside the (convex) shape, a mesh or an
    analytic sphere, found with the brute-force intersector: entry then exit, or only the exit
    for a camera inside."""
    geometry = scene.shapes[0].mesh
    if isinstance(geometry, meshes.Sphere):
        v = np.zeros((0, 3, 3))
        spheres = (geometry.center[None], np.array([geometry.radius]))
    else:
        v, spheres = geometry.vertices[geometry.faces], None
    directions = subpixel_rays(scene, samples_per_axis)
    shape = directions.shape[:-1]
    d = directions.reshape(-1, 3)
    origins = np.broadcast_to(scene.camera.position, d.shape)
    t_first, hit = intersect_brute_force(v[:, 0], v[:, 1], v[:, 2], origins, d, spheres=spheres)
    if camera_inside:
        return t_first.reshape(shape)
    inside = hit >= 0
    lengths = np.zeros(len(d))
    if np.any(inside):
        start = origins[inside] + d[inside] * (t_first[inside, None] + 1e-5)
        t_out, _ = intersect_brute_force(v[:, 0], v[:, 1], v[:, 2], start, d[inside], spheres=spheres)
        lengths[inside] = t_out + 1e-5
    return lengths.reshape(shape)


@pytest.mark.parametrize("analytic", [True, False], ids=["sphere", "icosphere"])
def test_pure_absorber_matches_exp_of_chord_length(device, analytic):
    sigma_a = np.array([0.3, 1.0, 2.5])
    scene = clrender.load_scene_dict(medium_scene(
        {"sigma_a": sigma_a.tolist()}, sphere(analytic, radius=1.0),
        camera_args={"resolution": (16, 16), "fov": 28}))
    result = clrender.Renderer(scene, device).render(spp=64, seed=8)
    assert result.discarded_samples == 0
    chords = chord_lengths(scene)
    expected = np.exp(-sigma_a * chords[..., None]).mean(axis=2)
    assert chords.max() > 1.9  # the sphere is crossed through its centre
    # Compare per chord-length band, so a wrong dependence on length cannot average out.
    mean_chord = chords.mean(axis=2)
    for low, high in [(0.01, 1.0), (1.0, 1.7), (1.7, 2.1)]:
        band = (mean_chord > low) & (mean_chord <= high)
        assert band.sum() >= 8
        for c in range(3):
            assert z_bound(result.image[..., c][band] - expected[..., c][band], 0.0) < 5.0


def test_camera_inside_an_absorbing_medium(device):
    sigma_a = 0.7
    scene = clrender.load_scene_dict(medium_scene(
        {"sigma_a": sigma_a}, {"type": "sphere", "radius": 2.0},
        camera_args={"position": (0.1, 0.2, 0.0), "look_at": (0, 0, -1), "resolution": (12, 12), "fov": 40}))
    result = clrender.Renderer(scene, device).render(spp=64, seed=2)
    assert clrender.Renderer(scene, device).arrays.camera_medium == 0
    chords = chord_lengths(scene, samples_per_axis=6, camera_inside=True)
    expected = np.exp(-sigma_a * chords).mean(axis=2)
    assert z_bound(result.image[..., 0] - expected, 0.0) < 5.0
    assert abs(result.image.mean() - np.exp(-sigma_a * 2.0)) < 0.1  # sanity: about exp(-0.7 * 2)


@pytest.mark.parametrize("medium,render", [
    ({"sigma_t": 1e-6, "albedo": 0.5}, {"max_depth": 16}),
    ({"sigma_t": 1e4, "albedo": 0.5}, {"max_depth": 16}),
    ({"sigma_t": 1e4, "albedo": 1.0}, {"max_depth": 40, "rr_depth": 100}),  # max depth reached
    ({"sigma_t": 3.0, "albedo": 0.9, "g": 0.999}, {"max_depth": 64}),
    ({"sigma_t": 3.0, "albedo": 0.9, "g": -0.999}, {"max_depth": 64}),
    ({"sigma_t": 3.0, "albedo": 0.9, "g": 0.99999999}, {"max_depth": 64}),   # g rounds to 1 in float32
    ({"sigma_t": 3.0, "albedo": 0.9, "g": -0.99999999}, {"max_depth": 64}),
    ({"sigma_a": [0, 0, 5], "sigma_s": [0, 1, 0]}, {"max_depth": 16}),   # channels with sigma_t = 0
])
def test_hard_media_stay_finite(device, medium, render):
    data = medium_scene(medium, {"type": "sphere", "radius": 1.0},
                        camera_args={"resolution": (12, 12)}, render=render,
                        lights=[{"type": "environment", "radiance": 1.0},
                                {"type": "point", "position": [0, 3, 0], "intensity": 5.0}])
    result = clrender.Renderer(clrender.load_scene_dict(data), device).render(spp=4, seed=1)
    assert result.discarded_samples == 0
    assert np.all(np.isfinite(result.image)) and np.all(result.image >= 0)


def test_fog_with_an_almost_clear_channel_stays_finite(device):
    # Found by fuzzing (tests/test_fuzz.py, random mode): in scene-wide fog whose red sigma_s is
    # 1e-20, a red hero flies ~1e20 before it scatters; a light's solid-angle pdf from there
    # squares past FLT_MAX and the power heuristic gave inf / inf (458 of 1024 samples were NaN).
    data = {
        "camera": camera(position=(0, 1, 6), look_at=(0, 0, 0), fov=10, resolution=(4, 4)),
        "media": [{"name": "fog", "sigma_a": 0.0, "sigma_s": [1e-20, 0.18, 0.125]}],
        "medium": "fog",
        "materials": [{"name": "lamp", "type": "emissive", "radiance": 1.0}],
        "shapes": [{"type": "rectangle", "material": "lamp",
                    "transform": {"translate": [0, 2.5, 0], "rotate": [90, 0, 0], "scale": 0.5}}],
        "render": {"max_depth": 3},
    }
    result = clrender.Renderer(clrender.load_scene_dict(data), device).render(spp=64, seed=0)
    assert result.discarded_samples == 0
    assert np.all(np.isfinite(result.image))


def test_scene_wide_fog_attenuates_a_directly_seen_light(device):
    # A camera in fog (no boundaries) looks at an emitter at distance 4: with max depth 1 the
    # pixel estimates L exp(-sigma_t * 4) exactly.
    sigma_t = 0.25
    data = {
        "camera": camera(position=(0, 0, 4), look_at=(0, 0, 0), fov=5, resolution=(8, 8)),
        "media": [{"name": "fog", "sigma_t": sigma_t, "albedo": 0.8}],
        "medium": "fog",
        "materials": [{"name": "lamp", "type": "emissive", "radiance": 3.0}],
        "shapes": [{"type": "rectangle", "material": "lamp"}],
        "render": {"max_depth": 1},
    }
    scene = clrender.load_scene_dict(data)
    result = clrender.Renderer(scene, device).render(spp=64, seed=3)
    # Grey medium: each sample is 3 * (passes ? 1 : 0); path lengths vary < 0.1% over the view.
    assert z_bound(result.image, 3.0 * np.exp(-sigma_t * 4.0)) < 5.0


@pytest.mark.parametrize("roughness", [0.0, 0.4])
def test_glass_filled_with_a_scattering_medium_vanishes_in_a_furnace(device, roughness):
    # A lossless medium behind a lossless dielectric boundary: refraction changes the medium
    # (the glass's interior), roulette must ignore the eta^2 radiance scale, and the whole
    # object must still vanish in a uniform environment.
    data = medium_scene({"sigma_t": [1.5, 0.8, 3.0], "albedo": 1.0, "g": 0.5},
                        {"type": "sphere", "radius": 1.0},
                        camera_args={"resolution": (16, 16), "fov": 25},
                        render={"max_depth": 1000, "rr_depth": 5})
    data["materials"] = [{"name": "boundary", "type": "dielectric", "ior": 1.5, "roughness": roughness}]
    scene = clrender.load_scene_dict(data)
    assert scene_features(scene)["MEDIA"] == 1 and scene_features(scene)["DIELECTRIC"] == 1
    result = clrender.Renderer(scene, device).render(spp=32, seed=12)
    assert result.discarded_samples == 0
    for c in range(3):
        assert z_bound(result.image[..., c], 1.0) < 5.0


def test_absorbing_glass_follows_beer_lambert_through_a_slab(device):
    # A camera looking perpendicularly through a glass slab filled with an absorber, in front of a
    # uniform background: transmitted radiance = (1 - R)^2 exp(-sigma_a d) / (1 - R^2 exp(-2 sigma_a d))
    # summing the inter-reflections inside the slab (R: normal-incidence Fresnel reflectance);
    # the 1/eta^2 radiance scale cancels between entering and leaving.
    sigma_a, thickness, ior = np.array([0.2, 1.0, 4.0]), 0.5, 1.5
    data = medium_scene({"sigma_a": sigma_a.tolist()}, SLAB,
                        camera_args={"fov": 3, "resolution": (16, 16)}, render={"max_depth": 64, "rr_depth": 64})
    data["materials"] = [{"name": "boundary", "type": "dielectric", "ior": ior}]
    result = clrender.Renderer(clrender.load_scene_dict(data), device).render(spp=64, seed=4)
    reflectance = ((ior - 1) / (ior + 1)) ** 2
    transmittance = np.exp(-sigma_a * thickness)
    expected = (1 - reflectance) ** 2 * transmittance / (1 - reflectance ** 2 * transmittance ** 2)
    # Camera rays and the background reflected by the front face also reach the camera:
    # a perpendicular reflection sends the ray back to the uniform background, which adds
    # R + (1 - R)^2 R T^2 / (1 - R^2 T^2) (the light reflected once or after inner bounces).
    expected += reflectance + (1 - reflectance) ** 2 * reflectance * transmittance ** 2 / (
        1 - reflectance ** 2 * transmittance ** 2)
    for c in range(3):
        assert z_bound(result.image[..., c], expected[c]) < 5.0, (c, result.image[..., c].mean(), expected[c])
