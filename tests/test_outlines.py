"""Auxiliary buffers (depth, normal, object id of the pixel-centre rays) and ink outlines."""
import numpy as np
import pytest

import clrender
from clrender import outlines
from conftest import camera


def render(data, spp=1, seed=1):
    result = clrender.Renderer(clrender.load_scene_dict(data)).render(spp=spp, seed=seed)
    assert result.discarded_samples == 0
    return result


def sphere_before_plane(outline_settings=None):
    """A toon sphere in front of a diffuse plane turned 68 degrees away: towards one side of the
    image the plane's depth grows by up to ~25 % per pixel, more than the depth threshold,
    without any discontinuity."""
    data = {
        "camera": camera(position=(0, 0, 0), look_at=(0, 0, -1), fov=40, resolution=(64, 64)),
        "materials": [{"name": "ball", "type": "toon", "color": [0.9, 0.5, 0.2]},
                      {"name": "wall", "type": "diffuse", "albedo": [0.6, 0.6, 0.6]}],
        "shapes": [{"type": "sphere", "material": "ball", "radius": 1.0, "center": [0, 0, -4]},
                   {"type": "rectangle", "material": "wall",
                    "transform": {"scale": 150, "rotate": [0, 68, 0], "translate": [0, 0, -10]}}],
        "lights": [{"type": "directional", "direction": [-0.5, -0.5, -1], "irradiance": 3.0}],
    }
    if outline_settings is not None:
        data["outlines"] = outline_settings
    return data


def flood(mask, seed):
    """Pixels of `mask` 4-connected to `seed`."""
    region = np.zeros_like(mask)
    region[seed] = mask[seed]
    while True:
        grown = region.copy()
        grown[1:] |= region[:-1]
        grown[:-1] |= region[1:]
        grown[:, 1:] |= region[:, :-1]
        grown[:, :-1] |= region[:, 1:]
        grown &= mask
        if np.array_equal(grown, region):
            return region
        region = grown


def near(mask, distance):
    """Pixels within `distance` (Chebyshev) of `mask`."""
    out = mask.copy()
    for dy in range(-distance, distance + 1):
        for dx in range(-distance, distance + 1):
            out |= np.roll(np.roll(mask, dy, axis=0), dx, axis=1)
    return out


# --------------------------------------------------------------------------------------------
# Auxiliary buffers
# --------------------------------------------------------------------------------------------
def test_aux_buffers_hold_planar_depth_normal_and_object_id():
    data = {
        "camera": camera(position=(0, 0, 5), look_at=(0, 0, 0), fov=30, resolution=(32, 32)),
        "materials": [{"name": "m", "type": "diffuse"}],
        "shapes": [{"type": "rectangle", "material": "m", "transform": {"scale": [1, 3, 1]}},
                   {"type": "rectangle", "material": "m",
                    "transform": {"scale": [3, 0.5, 1], "translate": [0, 0, 1]}}],
    }
    aux = render(data).aux
    ids = aux["object_id"]
    assert ids.shape == (32, 32) and ids.dtype == np.int32
    assert set(np.unique(ids)) == {-1, 0, 1}
    # Planar depth: the same for every pixel of a plane facing the camera.
    np.testing.assert_allclose(aux["depth"][ids == 0], 5.0, rtol=1e-6)
    np.testing.assert_allclose(aux["depth"][ids == 1], 4.0, rtol=1e-6)
    np.testing.assert_allclose(aux["normal"][ids >= 0], np.broadcast_to([0, 0, 1], ((ids >= 0).sum(), 3)),
                               atol=1e-6)
    assert np.all(aux["depth"][ids == -1] == 0) and np.all(aux["normal"][ids == -1] == 0)
    # The front rectangle is a horizontal band across the middle rows.
    assert np.all(ids[15:17] == 1) and np.all(ids[0, 10:22] == 0)


def test_aux_buffers_do_not_depend_on_seed_or_samples():
    scene = clrender.load_scene_dict(sphere_before_plane())
    renderer = clrender.Renderer(scene)
    a = renderer.render(spp=1, seed=1).aux
    b = renderer.render(spp=3, seed=8, samples_per_pass=1).aux
    for key in ("depth", "normal", "object_id"):
        assert np.array_equal(a[key], b[key]), key


# --------------------------------------------------------------------------------------------
# Outlines in rendered images
# --------------------------------------------------------------------------------------------
def test_sphere_in_front_of_a_plane_yields_a_closed_silhouette_ring():
    result = render(sphere_before_plane({"enabled": True, "width": 1.5, "color": [0, 0, 0]}))
    ids = result.aux["object_id"]
    assert np.all(ids >= 0)  # the plane fills the background: the ring lies on it
    ink = result.outline_alpha >= 0.5
    # Closed: the ink-free pixels reachable from the sphere's centre stay inside the silhouette.
    inside = flood(~ink, (32, 32))
    assert inside.sum() > 200
    assert np.all(ids[inside] == 0)
    assert not inside[[0, -1], :].any() and not inside[:, [0, -1]].any()
    # Only the silhouette: no ink on the receding plane or inside the sphere.
    boundary = np.zeros_like(ink)
    boundary[:, 1:] |= ids[:, 1:] != ids[:, :-1]
    boundary[1:] |= ids[1:] != ids[:-1]
    assert np.all(near(boundary, 2)[result.outline_alpha > 0])
    # Ink of colour 0 and coverage 0.75 on each side of an edge (width 1.5).
    assert np.isclose(result.outline_alpha.max(), 1.0) or np.isclose(result.outline_alpha.max(), 0.75)
    np.testing.assert_array_equal(result.image[result.outline_alpha == 1], 0)


def test_disabled_outlines_leave_the_image_unchanged():
    plain = render(sphere_before_plane())
    disabled = render(sphere_before_plane({"enabled": False, "width": 3}))
    enabled = render(sphere_before_plane({"width": 2, "color": [0.1, 0.2, 0.3]}))
    assert plain.outline_alpha is None and disabled.outline_alpha is None
    assert np.array_equal(plain.image, disabled.image)
    alpha = enabled.outline_alpha
    assert alpha.max() == 1.0
    untouched = alpha == 0
    assert untouched.sum() > 0.8 * alpha.size
    assert np.array_equal(enabled.image[untouched], plain.image[untouched])
    expected = plain.image * (1 - alpha[..., None]) + np.float32([0.1, 0.2, 0.3]) * alpha[..., None]
    np.testing.assert_allclose(enabled.image, expected, rtol=1e-6, atol=1e-7)


# --------------------------------------------------------------------------------------------
# Edge detection and coverage on synthetic buffers
# --------------------------------------------------------------------------------------------
def synthetic_aux(depth, normal=None, ids=None):
    depth = np.asarray(depth, dtype=np.float32)
    if normal is None:
        normal = np.broadcast_to(np.float32([0, 0, 1]), depth.shape + (3,)).copy()
    if ids is None:
        ids = np.zeros(depth.shape, np.int32)
    return {"depth": depth, "normal": normal, "object_id": ids}


def test_planes_at_any_slope_have_no_edges():
    y, x = np.mgrid[0:24, 0:24].astype(float)
    inverse_depth = 0.05 + 0.012 * x + 0.004 * y  # 1 / depth is affine over a plane
    aux = synthetic_aux(1.0 / inverse_depth)
    assert (np.diff(aux["depth"], axis=1) / aux["depth"][:, 1:]).min() < -0.1  # steep
    edge_x, edge_y = outlines.edges(aux, depth_threshold=0.1)
    assert not edge_x.any() and not edge_y.any()


def test_depth_jump_on_one_object_is_an_edge():
    depth = np.full((8, 12), 4.0)
    depth[:, 6:] = 5.0  # the same object folds behind itself
    edge_x, edge_y = outlines.edges(synthetic_aux(depth), depth_threshold=0.1)
    assert np.array_equal(np.flatnonzero(edge_x.any(axis=0)), [5]) and edge_x[:, 5].all()
    assert not edge_y.any()
    edge_x, _ = outlines.edges(synthetic_aux(depth), depth_threshold=0.3)
    assert not edge_x.any()  # a 20 % jump is below a 30 % threshold


@pytest.mark.parametrize("angle,threshold,is_edge", [(90, 30, True), (20, 30, False), (40, 30, True),
                                                     (90, 180, False)])
def test_creases_follow_the_angle_between_normals(angle, threshold, is_edge):
    normal = np.zeros((6, 10, 3), np.float32)
    normal[..., 2] = 1
    a = np.radians(angle)
    normal[:, 5:] = [np.sin(a), 0, np.cos(a)]
    edge_x, edge_y = outlines.edges(synthetic_aux(np.full((6, 10), 3.0), normal), crease_angle=threshold)
    assert edge_x[:, 4].all() == is_edge and edge_x.sum() == (6 if is_edge else 0)
    assert not edge_y.any()


def test_object_id_changes_are_silhouettes():
    ids = np.zeros((6, 10), np.int32)
    ids[2:4, 3:7] = 1
    ids[0, 0] = -1
    edge_x, edge_y = outlines.edges(synthetic_aux(np.full((6, 10), 3.0), ids=ids))
    assert edge_x.sum() == 2 * 2 + 1 and edge_y.sum() == 2 * 4 + 1


@pytest.mark.parametrize("width,profile", [(1.0, [0, 0, 0.5, 0.5, 0, 0]), (1.5, [0, 0, 0.75, 0.75, 0, 0]),
                                           (2.0, [0, 0, 1, 1, 0, 0]), (3.0, [0, 0.5, 1, 1, 0.5, 0])])
def test_line_coverage_is_a_box_filtered_line_of_the_width(width, profile):
    edge_x = np.zeros((5, 5), bool)
    edge_x[:, 2] = True  # a vertical edge between columns 2 and 3 of a 5 x 6 image
    alpha = outlines.coverage(edge_x, np.zeros((4, 6), bool), (5, 6), width)
    np.testing.assert_allclose(alpha, np.broadcast_to(profile, (5, 6)), atol=1e-6)


@pytest.mark.parametrize("settings,where,message", [
    ({"width": 0}, "outlines.width", "must be > 0"),
    ({"crease_angle": 0}, "outlines.crease_angle", "must be > 0"),
    ({"crease_angle": 200}, "outlines.crease_angle", "must be <= 180"),
    ({"depth_threshold": -1}, "outlines.depth_threshold", "must be > 0"),
    ({"color": [0, 0, -1]}, "outlines.color", "non-negative"),
    ({"enabled": 1}, "outlines.enabled", "true or false"),
    ({"colour": [0, 0, 0]}, "outlines.colour", "unknown field"),
])
def test_invalid_outline_settings_are_reported_with_their_place(settings, where, message):
    with pytest.raises(clrender.SceneError) as error:
        clrender.load_scene_dict(sphere_before_plane(settings))
    text = str(error.value)
    assert text.startswith(where + ":") and message in text, text


def test_outline_settings_defaults():
    scene = clrender.load_scene_dict(sphere_before_plane({}))
    o = scene.outlines
    assert (o.enabled, o.width, o.depth_threshold, o.crease_angle, o.color.tolist()) == (
        True, 1.5, 0.1, 30.0, [0, 0, 0])
    assert clrender.load_scene_dict(sphere_before_plane()).outlines.enabled is False
