"""Auxiliary outputs (clrender/aovs.py, kernels/aovs.h): albedo, normal, variance, depth, object id."""
import numpy as np
import pytest

import clrender
from clrender.aovs import AOV_NAMES, parse_aovs
from conftest import camera, z_bound

ALL = ("albedo", "normal", "emission", "variance", "depth", "object_id")


def render(data, device, spp=4, seed=1, aovs=ALL, **options):
    result = clrender.Renderer(clrender.load_scene_dict(data), device).render(
        spp=spp, seed=seed, aovs=aovs, **options)
    assert result.discarded_samples == 0
    return result


def interior(mask):
    """Pixels of `mask` whose 8 neighbours are in it too (no pixel footprint crosses an edge)."""
    inner = mask.copy()
    inner[0, :] = inner[-1, :] = inner[:, 0] = inner[:, -1] = False
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            inner &= np.roll(np.roll(mask, dy, axis=0), dx, axis=1)
    return inner


def wall_scene(material, resolution=(16, 12)):
    """A rectangle filling the view, lit by a point light beside the camera."""
    return {
        "camera": camera(position=(0, 0, 3), look_at=(0, 0, 0), fov=30, resolution=resolution),
        "materials": [dict(name="wall", **material)],
        "shapes": [{"type": "rectangle", "material": "wall", "transform": {"scale": 4}}],
        "lights": [{"type": "point", "position": [0.5, 0.5, 2], "intensity": 3}],
    }


def test_diffuse_wall_albedo_equals_its_albedo_and_normals_face_the_camera(device):
    result = render(wall_scene({"type": "diffuse", "albedo": [0.3, 0.5, 0.7]}), device)
    albedo, normal = result.aovs["albedo"], result.aovs["normal"]
    assert albedo.shape == normal.shape == (12, 16, 3) and albedo.dtype == np.float32
    np.testing.assert_allclose(albedo, np.broadcast_to([0.3, 0.5, 0.7], albedo.shape), rtol=1e-6)
    np.testing.assert_allclose(normal, np.broadcast_to([0, 0, 1], normal.shape), atol=1e-6)
    assert np.all(result.aovs["emission"] == 0.0)   # all its light is reflected


@pytest.mark.parametrize("roughness", [0.0, 0.3])
def test_plastic_albedo_is_its_diffuse_reflectance(device, roughness):
    # docs/denoising.md: the base's colour, smooth coat or rough (a smooth plastic is no delta
    # vertex: its base is diffuse).
    material = {"type": "plastic", "diffuse": [0.3, 0.5, 0.7], "specular": 0.8, "roughness": roughness}
    albedo = render(wall_scene(material), device).aovs["albedo"]
    np.testing.assert_allclose(albedo, np.broadcast_to([0.3, 0.5, 0.7], albedo.shape), rtol=1e-6)


def test_normals_are_unit_and_face_the_camera_on_a_sphere(device):
    data = {
        "camera": camera(position=(0, 0, 4), look_at=(0, 0, 0), fov=40, resolution=(24, 24)),
        "materials": [{"name": "m", "type": "diffuse"}],
        "shapes": [{"type": "sphere", "material": "m", "radius": 1.0}],
        "lights": [{"type": "environment", "radiance": 1.0}],
    }
    scene = clrender.load_scene_dict(data)
    px, py = np.meshgrid(np.arange(24) + 0.5, np.arange(24) + 0.5)
    view = scene.camera.pixel_directions(px, py)
    for spp in (1, 8):
        result = render(data, device, spp=spp)
        on_sphere = interior(result.aovs["object_id"] == 0)
        assert on_sphere.sum() > 100
        normal = result.aovs["normal"][on_sphere]
        length = np.linalg.norm(normal, axis=1)
        # One sample: unit. Several: their mean over the pixel's footprint (a few degrees of the
        # sphere, most near the silhouette) is shorter, by about angle^2 / 24.
        if spp == 1:
            np.testing.assert_allclose(length, 1.0, atol=1e-5)
        else:
            assert np.all((length > 0.99) & (length < 1 + 1e-5))
        assert np.all(np.sum(normal * view[on_sphere], axis=1) < -0.1)
    # Escaped rays see the environment: albedo its (scaled) colour, normal 0; black when the
    # environment is hidden from camera rays.
    sky = interior(result.aovs["object_id"] == -1)
    assert sky.sum() > 20
    assert np.all(result.aovs["albedo"][sky] == 1.0) and np.all(result.aovs["normal"][sky] == 0.0)
    hidden = render(dict(data, render={"hide_environment": True}), device, spp=8, aovs=("albedo",))
    assert np.all(hidden.aovs["albedo"][sky] == 0.0)
    np.testing.assert_array_equal(hidden.aovs["albedo"][on_sphere], result.aovs["albedo"][on_sphere])


def mirror_scene(resolution=(16, 16)):
    """A mirror at 45 degrees fills the view; it reflects the camera's rays along +x onto a
    diffuse wall at x = 3 that faces -x."""
    return {
        "camera": camera(position=(0, 0, 0), look_at=(0, 0, -1), fov=10, resolution=resolution),
        "materials": [{"name": "mirror", "type": "conductor", "tint": 0.9},
                      {"name": "wall", "type": "diffuse", "albedo": [0.2, 0.6, 0.4]}],
        "shapes": [{"type": "rectangle", "material": "mirror", "name": "mirror",
                    "transform": {"rotate": [0, 45, 0], "translate": [0, 0, -3]}},
                   {"type": "rectangle", "material": "wall",
                    "transform": {"scale": 10, "rotate": [0, -90, 0], "translate": [3, 0, -3]}}],
        "lights": [{"type": "point", "position": [1, 0, -3], "intensity": 3}],
    }


def test_through_a_mirror_albedo_and_normal_are_the_reflected_surfaces(device):
    result = render(mirror_scene(), device)
    albedo, normal = result.aovs["albedo"], result.aovs["normal"]
    # The mirror's tint filters the reflected albedo; the normal is the wall's, facing the ray.
    np.testing.assert_allclose(albedo, np.broadcast_to(np.float32(0.9) * np.float32([0.2, 0.6, 0.4]),
                                                       albedo.shape), rtol=1e-6)
    np.testing.assert_allclose(normal, np.broadcast_to([-1, 0, 0], normal.shape), atol=1e-5)
    # Depth and object id stay those of the pixel-centre hit: the mirror.
    assert np.all(result.aovs["object_id"] == 0)
    assert np.all(np.abs(result.aovs["depth"] - 3.0) < 0.3)


def test_emission_is_the_emitted_part_of_the_colour_through_a_mirror(device):
    """An emitter seen in a mirror of tint 0.9 and nothing else: colour and emission are both
    0.9 x its radiance, bit for bit (the same product the colour adds)."""
    data = mirror_scene()
    data["materials"][1] = {"name": "wall", "type": "emissive", "radiance": [2, 3, 4]}
    del data["lights"]
    result = render(data, device)
    expected = np.float32(0.9) * np.float32([2, 3, 4])
    assert np.array_equal(result.aovs["emission"], np.broadcast_to(expected, (16, 16, 3)))
    assert np.array_equal(result.image, result.aovs["emission"])
    np.testing.assert_allclose(result.aovs["albedo"], np.broadcast_to(np.float32(0.9) * np.float32([2, 3, 4]) / 4,
                                                                      (16, 16, 3)), rtol=1e-6)


def window_scene(ior):
    """A glass pane (two facing rectangles, tint 0.8) in front of a diffuse wall; nothing else
    (escaped rays: albedo 0)."""
    pane = {"type": "box", "material": "glass", "transform": {"scale": [3, 3, 0.05], "translate": [0, 0, -2]}}
    return {
        "camera": camera(position=(0, 0, 0), look_at=(0, 0, -1), fov=10, resolution=(16, 16)),
        "render": {"max_depth": 64, "rr_depth": 64},
        "materials": [{"name": "glass", "type": "dielectric", "ior": ior, "tint": 0.8},
                      {"name": "wall", "type": "diffuse", "albedo": [0.2, 0.6, 0.4]}],
        "shapes": [pane, {"type": "rectangle", "material": "wall",
                          "transform": {"scale": 10, "translate": [0, 0, -4]}}],
        "lights": [{"type": "point", "position": [0, 1, -3], "intensity": 3}],
    }


def test_through_index_matched_glass_the_albedo_carries_the_tint(device):
    result = render(window_scene(ior=1.0), device)
    expected = np.float32(0.8) * np.float32(0.8) * np.float32([0.2, 0.6, 0.4])
    np.testing.assert_allclose(result.aovs["albedo"], np.broadcast_to(expected, (16, 16, 3)), rtol=1e-6)
    np.testing.assert_allclose(result.aovs["normal"], np.broadcast_to([0, 0, 1], (16, 16, 3)), atol=1e-6)


def test_through_smooth_glass_the_albedo_is_the_fresnel_blend(device):
    """At (near) normal incidence on a pane of ior 1.5 (F = 0.04 per interface), a path reaches
    the wall after 2 refractions and 2k internal reflections (k >= 0), with probability
    (1 - F)^2 / (1 - F^2) and the tint twice; otherwise it leaves towards the camera side, where
    nothing is (albedo 0). The normal is the wall's on the same paths."""
    spp = 64
    result = render(window_scene(ior=1.5), device, spp=spp)
    f = ((1.5 - 1) / (1.5 + 1)) ** 2
    reach = (1 - f) ** 2 / (1 - f * f)
    albedo = result.aovs["albedo"].reshape(-1, 3)
    for c, wall in enumerate([0.2, 0.6, 0.4]):
        assert z_bound(albedo[:, c], reach * 0.64 * wall) < 5
    assert z_bound(result.aovs["normal"].reshape(-1, 3)[:, 2], reach) < 5


def test_dense_medium_albedo_is_the_single_scattering_albedo(device):
    """Inside a box of dense fog every camera path scatters (optical depth 200 before the back
    face): albedo sigma_s / sigma_t, normal 0 (no surface)."""
    data = {
        "camera": camera(position=(0, 0, 3), look_at=(0, 0, 0), fov=20, resolution=(12, 12)),
        "materials": [{"name": "boundary", "type": "interface"}],
        "media": [{"name": "fog", "sigma_a": [100, 20, 50], "sigma_s": [100, 80, 25]}],
        "shapes": [{"type": "box", "material": "boundary", "interior": "fog"}],
        "lights": [{"type": "environment", "radiance": 1.0}],
    }
    result = render(data, device)
    expected = np.float32([100, 80, 25]) / np.float32([200, 100, 75])
    np.testing.assert_allclose(result.aovs["albedo"], np.broadcast_to(expected, (12, 12, 3)), rtol=1e-6)
    assert np.all(result.aovs["normal"] == 0.0)


def half_emitter_scene(width=33, height=20):
    """An emitter covering the right half of the view exactly: its edge (x = 0) runs down the
    middle of the centre column of an odd-width image; black elsewhere (no environment)."""
    return {
        "camera": camera(position=(0, 0, 2), look_at=(0, 0, 0), fov=30, resolution=(width, height)),
        "materials": [{"name": "light", "type": "emissive", "radiance": [2, 3, 8]}],
        "shapes": [{"type": "rectangle", "material": "light", "transform": {"translate": [1, 0, 0]}}],
    }


def test_variance_is_the_variance_of_the_pixel_mean(device):
    """On the centre column each sample is the radiance L with probability 1/2, else 0: the
    variance of one sample is L^2 / 4, and n times the variance AOV estimates it without bias.
    Elsewhere every sample is the same: variance exactly 0 (no cancellation error). The AOV
    assumes independent samples (Sobol's stratify the coverage: docs/denoising.md)."""
    spp = 16
    result = render(dict(half_emitter_scene(), render={"sampler": "independent"}), device, spp=spp,
                    aovs=("variance", "albedo"))
    variance = result.aovs["variance"]
    radiance = np.array([2, 3, 8])
    for c in range(3):
        assert z_bound(spp * variance[:, 16, c], radiance[c] ** 2 / 4) < 5
    for columns in (np.s_[:, :16], np.s_[:, 17:]):
        assert np.all(variance[columns] == 0.0)
    # An emitter's albedo is its emission scaled to a maximum of 1.
    np.testing.assert_allclose(result.aovs["albedo"][:, 17:], np.broadcast_to(radiance / 8, (20, 16, 3)),
                               rtol=1e-6)
    # The colour is all emission; on the centre column both hold the same coverage noise.
    emission = render(half_emitter_scene(), device, spp=spp, aovs=("emission",))
    assert np.array_equal(emission.aovs["emission"], emission.image)
    one = render(half_emitter_scene(), device, spp=1, aovs=("variance",))
    assert np.all(np.isinf(one.aovs["variance"]))   # unknown from a single sample


@pytest.mark.parametrize("data", [mirror_scene((12, 10)), window_scene(1.5), half_emitter_scene()],
                         ids=["mirror", "glass", "emitter"])
def test_aovs_leave_the_colour_bit_identical_and_are_deterministic(device, data):
    scene = clrender.load_scene_dict(data)
    plain = clrender.Renderer(scene, device).render(spp=6, seed=3)
    renderer = clrender.Renderer(scene, device)
    whole = renderer.render(spp=6, seed=3, aovs=ALL, samples_per_pass=6)
    split = renderer.render(spp=6, seed=3, aovs=ALL, samples_per_pass=4)
    groups = clrender.Renderer(scene, device, local_size=(4, 2)).render(spp=6, seed=3, aovs=ALL,
                                                                         samples_per_pass=1)
    assert np.array_equal(plain.image, whole.image)
    for other in (split, groups):
        assert np.array_equal(whole.image, other.image)
        for name in ALL:
            assert np.array_equal(whole.aovs[name], other.aovs[name]), name


def test_depth_and_object_id_are_the_pixel_centre_record(device):
    result = render(mirror_scene(), device, aovs=("depth", "object_id"))
    assert set(result.aovs) == {"depth", "object_id"}
    assert result.aovs["object_id"].dtype == np.int32
    np.testing.assert_array_equal(result.aovs["object_id"], result.aux["object_id"])
    np.testing.assert_array_equal(result.aovs["depth"], result.aux["depth"])
    escaped = render(half_emitter_scene(), device, aovs=("depth", "object_id")).aovs
    assert np.all(np.isinf(escaped["depth"][:, :16])) and np.all(escaped["object_id"][:, :16] == -1)


def test_aovs_at_analytic_spheres_match_the_closed_form(device):
    # A diffuse sphere and an emissive one (analytic): the pixel-centre records (object id, depth)
    # equal the closed-form nearest hit of each centre ray, and pixels wholly on a sphere have its
    # albedo (the emitter's radiance scaled to a maximum of 1) and, on the emitter, exactly its
    # radiance as emission (every sample sees the front face directly).
    centres, radii = np.array([[0.3, -0.2, 0.0], [-1.0, 0.8, 0.5]]), np.array([1.0, 0.3])
    data = {
        "camera": camera(position=(0, 0, 4), look_at=(0, 0, 0), fov=50, resolution=(32, 32)),
        "materials": [{"name": "m", "type": "diffuse", "albedo": [0.2, 0.4, 0.6]},
                      {"name": "lamp", "type": "emissive", "radiance": [4.0, 2.0, 1.0]}],
        "shapes": [{"type": "sphere", "material": "m", "center": centres[0].tolist(), "radius": 1.0},
                   {"type": "sphere", "material": "lamp", "center": centres[1].tolist(), "radius": 0.3}],
        "lights": [{"type": "point", "position": [2, 2, 3], "intensity": 5}],
    }
    result = render(data, device)
    scene = clrender.load_scene_dict(data)
    px, py = np.meshgrid(np.arange(32) + 0.5, np.arange(32) + 0.5)
    d = scene.camera.pixel_directions(px, py)
    oc = centres[:, None, None, :] - scene.camera.position
    b = np.einsum("kyxi,yxi->kyx", oc, d)
    disc = b * b - (np.sum(oc * oc, axis=-1) - radii[:, None, None] ** 2)
    t = np.where(disc > 0, b - np.sqrt(np.maximum(disc, 0)), np.inf)
    expected_id = np.where(np.isinf(t.min(axis=0)), -1, t.argmin(axis=0))
    clear = np.all(np.abs(disc) > 1e-3 * radii[:, None, None] ** 2, axis=0)   # no grazing centre ray
    assert clear.sum() > 900
    np.testing.assert_array_equal(result.aovs["object_id"][clear], expected_id[clear])
    hit = clear & (expected_id >= 0)
    forward = scene.camera.basis()[0]
    np.testing.assert_allclose(result.aovs["depth"][hit], (t.min(axis=0) * (d @ forward))[hit], rtol=1e-5)
    ball, lamp = interior(expected_id == 0), interior(expected_id == 1)
    assert ball.sum() > 150 and lamp.sum() > 4
    np.testing.assert_allclose(result.aovs["albedo"][ball], np.broadcast_to([0.2, 0.4, 0.6], (ball.sum(), 3)), rtol=1e-6)
    np.testing.assert_allclose(result.aovs["albedo"][lamp], np.broadcast_to([1.0, 0.5, 0.25], (lamp.sum(), 3)), rtol=1e-6)
    np.testing.assert_allclose(result.aovs["emission"][lamp], np.broadcast_to([4.0, 2.0, 1.0], (lamp.sum(), 3)), rtol=1e-6)
    assert np.all(result.aovs["emission"][ball] == 0.0)


def test_aov_names_are_checked():
    assert parse_aovs("normal, albedo") == ("albedo", "normal")
    assert parse_aovs(AOV_NAMES[::-1]) == AOV_NAMES
    with pytest.raises(clrender.ArgumentError, match="--aov: unknown AOV 'albedos'"):
        parse_aovs("albedo,albedos", source="--aov")


def test_cli_writes_aovs_and_rejects_bad_flags(tmp_path):
    import os
    import subprocess
    import sys

    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

    def run(*args):
        return subprocess.run([sys.executable, "-m", "clrender.cli", "render", "scenes/cornell_box.json", "--spp",
                               "1", "--quiet", *args], capture_output=True, text=True, cwd=repo, timeout=300)

    result = run("-o", str(tmp_path / "cb.png"), "--aov", "normal,object_id")
    assert result.returncode == 0, result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cb.normal.png", "cb.object_id.png", "cb.png"]
    for args, message in ((("--aov", "albedo,shadow"), "--aov: unknown AOV 'shadow'"),
                          (("--keep-noisy",), "--keep-noisy: only with --denoise"),
                          (("--denoise-prefilter",), "--denoise-prefilter: only with --denoise")):
        result = run("-o", str(tmp_path / "bad.exr"), *args)
        assert result.returncode == 2 and message in result.stderr and "Traceback" not in result.stderr
        assert not (tmp_path / "bad.exr").exists()


def test_aov_sums_chain_across_accumulations_and_tiles(device):
    """Chained sample ranges (distributed.py's chunks) give the sums of one render, bit for bit,
    and a tile's sums are those of its pixels in the whole image."""
    from clrender.render import Accumulation, image_result

    scene = clrender.load_scene_dict(window_scene(1.5))
    renderer = clrender.Renderer(scene, device)
    width, height = scene.camera.resolution
    whole = renderer.accumulate(Accumulation.start((0, 0, width, height), sample_aovs=True), 6, seed=3)
    chained = Accumulation.start((0, 0, width, height), sample_aovs=True)
    for samples in (2, 1, 3):
        chained = renderer.accumulate(chained, samples, seed=3)
    assert whole.aov_sums.tobytes() == chained.aov_sums.tobytes()
    one = renderer.render(spp=6, seed=3, aovs=ALL)
    again = image_result(scene, chained, ALL)
    for name in ALL:
        assert np.array_equal(one.aovs[name], again.aovs[name]), name
    tile = renderer.accumulate(Accumulation.start((5, 3, 7, 6), sample_aovs=True), 6, seed=3)
    inside = whole.aov_sums.reshape(height, width)[3:9, 5:12].reshape(-1)
    assert tile.aov_sums.tobytes() == inside.tobytes()
