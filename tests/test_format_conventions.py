"""Scene-format features that carry Mitsuba 3's conventions (docs/scene-format.md): the `disk`
shape, one-sided materials (`two_sided: false`), single-scattering rough lobes
(`energy_compensation: false`) and `render.hide_environment`.

Exact cases compare exactly (a delta light and no environment: every sample of a pixel is the
same number); statistical ones require |mean - expected| < 5 standard errors (fixed seeds).
About 15 s on 2 cores (four small kernel builds).
"""
import numpy as np
import pytest

import clrender
from clrender import layout, meshes
from clrender.arrays import build_scene_arrays
from conftest import camera, z_bound


def test_disk_is_a_unit_disk_facing_up_with_the_exact_area():
    disk = meshes.disk(64)
    v = disk.vertices[disk.faces]
    cross = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    assert np.all(cross[:, 2] > 0) and np.allclose(cross[:, :2], 0)
    assert np.isclose(0.5 * cross[:, 2].sum(), np.pi, rtol=1e-12)
    assert np.all(v[:, 0] == 0)   # a fan around the centre
    rim = np.linalg.norm(v[:, 1:], axis=2)
    assert np.allclose(rim, rim[0, 0])


def test_disk_segments_are_checked():
    scene = {"camera": camera(), "materials": [{"name": "m", "type": "diffuse"}],
             "shapes": [{"type": "disk", "material": "m", "segments": 2}]}
    with pytest.raises(clrender.SceneError, match=r"shapes\[0\]\.segments: must be >= 3"):
        clrender.load_scene_dict(scene)


def lit_panel(material, flip):
    """A panel at the origin, lit along -z by a directional light from the camera's side (z = 5);
    `flip` turns its front face away from the camera and the light."""
    return clrender.load_scene_dict({
        "camera": camera(fov=20, resolution=(8, 8)),
        "materials": [dict(material, name="m")],
        "shapes": [{"type": "rectangle", "material": "m", "transform": {"scale": 3}, "flip_normals": flip}],
        "lights": [{"type": "directional", "direction": [0, 0, -1], "irradiance": 1.0}],
        "render": {"max_depth": 4},
    })


@pytest.mark.parametrize("two_sided,flip,expected", [
    (True, False, 0.5 / np.pi), (True, True, 0.5 / np.pi), (False, False, 0.5 / np.pi), (False, True, 0.0)])
def test_one_sided_diffuse_is_black_from_behind(device, two_sided, flip, expected):
    scene = lit_panel({"type": "diffuse", "albedo": [0.5] * 3, "two_sided": two_sided}, flip)
    image = clrender.Renderer(scene, device).render(spp=4, seed=1).image
    assert np.allclose(image, expected, rtol=1e-6, atol=0)


@pytest.mark.parametrize("two_sided,flip,expected", [(True, True, 0.7), (False, False, 0.7), (False, True, 0.0)])
def test_one_sided_mirror_is_black_from_behind(device, two_sided, flip, expected):
    # A tilted mirror reflecting a uniform environment shows tint x radiance.
    scene = clrender.load_scene_dict({
        "camera": camera(fov=20, resolution=(8, 8)),
        "materials": [{"name": "m", "type": "conductor", "tint": 0.7, "two_sided": two_sided}],
        "shapes": [{"type": "rectangle", "material": "m", "flip_normals": flip,
                    "transform": {"scale": 3, "rotate": [30, 0, 0]}}],
        "lights": [{"type": "environment", "radiance": 1.0}],
        "render": {"max_depth": 4, "hide_environment": True},
    })
    image = clrender.Renderer(scene, device).render(spp=4, seed=1).image
    assert np.allclose(image, expected, rtol=1e-6, atol=0)


def test_hide_environment_blacks_out_escaped_camera_rays_only(device):
    # A convex diffuse sphere in a uniform environment reflects albedo x radiance; with the
    # environment hidden the sphere is unchanged and the background black.
    def scene(hide):
        return clrender.load_scene_dict({
            "camera": camera(resolution=(24, 24), fov=30),
            "materials": [{"name": "m", "type": "diffuse", "albedo": [0.5] * 3}],
            "shapes": [{"type": "sphere", "material": "m"}],
            "lights": [{"type": "environment", "radiance": 1.0}],
            "render": {"max_depth": 8, "hide_environment": hide},
        })
    visible = clrender.Renderer(scene(False), device).render(spp=32, seed=2).image
    hidden = clrender.Renderer(scene(True), device).render(spp=32, seed=2).image
    background = visible[..., 0] == 1.0
    assert background.sum() > 100
    assert np.all(hidden[background] == 0.0)
    covered = (visible[..., 0] != 1.0) & (hidden[..., 0] > 0)
    assert covered.sum() > 100
    interior = np.all(hidden == visible, axis=2)   # the same samples where no camera ray escapes
    assert interior.sum() > 100
    assert z_bound(hidden[interior], 0.5) < 5.0


def rough_mirror_ball(compensated):
    # The whole image lies inside the ball's outline (corners at 9.9 deg < asin(1/5) = 11.5 deg).
    return clrender.load_scene_dict({
        "camera": camera(resolution=(16, 16), fov=14),
        "materials": [{"name": "m", "type": "conductor", "roughness": 1.0,
                       "energy_compensation": compensated}],
        "shapes": [{"type": "sphere", "material": "m"}],
        "lights": [{"type": "environment", "radiance": 1.0}],
        "render": {"max_depth": 32, "rr_depth": 16},
    })


def test_energy_compensation_off_leaves_the_single_scattering_lobe(device):
    # A white rough mirror in a furnace: compensated it vanishes (radiance 1), single scattering
    # loses the light its relief masks (a third or more at roughness 1).
    on, off = rough_mirror_ball(True), rough_mirror_ball(False)
    tables = lambda scene: layout.field(build_scene_arrays(scene).materials[0], layout.MATERIAL_FIELDS,  # noqa: E731
                                        "albedo_tables")
    assert tables(on) >= 0 and tables(off) == -1
    image_on = clrender.Renderer(on, device).render(spp=16, seed=4).image
    image_off = clrender.Renderer(off, device).render(spp=16, seed=4).image
    assert z_bound(image_on, 1.0) < 5.0
    assert image_off.mean() < 0.85
