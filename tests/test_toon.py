"""Toon material: bands, shadows, highlight, rim, several lights, area and environment lights,
and the path-vertex rule (a vertex hitting toon adds throughput * toon radiance and stops).

Delta lights make toon radiance deterministic: those tests are exact (float32 rounding only).
Area and environment lights are sampled: those tests use the standard error (conftest.z_bound).
With 1 sample per pixel every pixel value is the radiance of exactly one camera ray, so sets of
distinct values can be counted.
"""
import numpy as np
import pytest

import clrender
from clrender.arrays import build_scene_arrays
from clrender.features import scene_features
from conftest import camera, z_bound

INV_PI = 1.0 / np.pi


def toon(name="toon", color=(0.8, 0.5, 0.0), highlight_size=0.0, **fields):
    """A toon material dict; the highlight is off unless asked for (rim is off by default)."""
    material = {"name": name, "type": "toon", "color": list(color),
                "highlight": {"size": highlight_size}}
    material.update(fields)
    return material


def render(data, spp=1, seed=3, **settings):
    scene = clrender.load_scene_dict(data)
    result = clrender.Renderer(scene).render(spp=spp, seed=seed, **settings)
    assert result.discarded_samples == 0
    return result


def interior(mask):
    """Pixels of `mask` whose 8 neighbours are in it too: their jittered samples stay in it."""
    inner = mask.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            inner &= np.roll(np.roll(mask, dy, axis=0), dx, axis=1)
    inner[[0, -1], :] = inner[:, [0, -1]] = False
    return inner


def centre_points(scene, aux):
    """World positions of the pixel-centre hits (as the kernel's aux pass traced them) and the
    unit directions back to the camera."""
    c = scene.camera
    width, height = c.resolution
    px, py = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    d = c.pixel_directions(px, py)
    forward = c.basis()[0]
    t = aux["depth"][..., None] / (d @ forward)[..., None]
    points = c.position + d * t
    return points, -d


# --------------------------------------------------------------------------------------------
# Bands, shadow factor, highlight, rim
# --------------------------------------------------------------------------------------------
def lit_sphere(material, light_direction, irradiance=2.0, resolution=(48, 48), smooth=False,
               lights=None):
    return {
        "camera": camera(resolution=resolution, fov=28),
        "materials": [material],
        "shapes": [{"type": "sphere", "mesh": True, "material": material["name"], "radius": 1.0,
                    "subdivisions": 4, "smooth": smooth}],
        "lights": lights or [{"type": "directional", "direction": list(light_direction),
                              "irradiance": irradiance}],
    }


@pytest.mark.parametrize("bands", [1, 2, 4])
def test_bands_give_n_plus_one_diffuse_levels(bands):
    # Light from the side: the visible half holds every N.L in [-0.5, 1]. Flat facets keep the
    # test about the bands: on a convex polyhedron a lit facet never shadows itself.
    shadow, color, irradiance = 0.25, np.array([0.8, 0.5, 0.0]), 2.0
    material = toon(color=color, bands=bands, softness=0.0, shadow_color=[shadow] * 3)
    result = render(lit_sphere(material, (-np.sqrt(3) / 2, 0, -0.5), irradiance))
    values = result.image[result.image[..., 0] > 0]
    levels = np.unique(values, axis=0)
    expected = np.array([color * irradiance * INV_PI * (shadow + (1 - shadow) * k / bands)
                         for k in range(bands + 1)])
    assert len(levels) == bands + 1, levels
    np.testing.assert_allclose(levels, expected, rtol=1e-6)
    for level in levels:  # each tone covers a visible area, not a stray pixel
        assert np.sum(np.all(values == level, axis=1)) >= 10


def test_band_softness_blends_between_levels():
    material = toon(bands=2, softness=0.2)
    result = render(lit_sphere(material, (-np.sqrt(3) / 2, 0, -0.5)))
    values = np.unique(result.image[result.image[..., 0] > 0][:, 0])
    assert len(values) > 10  # the soft edges take intermediate values


def shadowed_floor(material, light_direction, irradiance=3.0):
    """A toon floor (y = 0) seen from above, a black plate at y = 1 casting a shadow on it."""
    return {
        "camera": camera(position=(0, 6, 0), look_at=(0, 0, 0), up=(0, 0, -1), fov=40,
                         resolution=(40, 40)),
        "materials": [material, {"name": "black", "type": "diffuse", "albedo": [0, 0, 0]}],
        "shapes": [
            {"type": "rectangle", "material": material["name"],
             "transform": {"scale": 3, "rotate": [-90, 0, 0]}},
            {"type": "rectangle", "material": "black",
             "transform": {"scale": 0.6, "rotate": [90, 0, 0], "translate": [-0.8, 1, 0]}},
        ],
        "lights": [{"type": "directional", "direction": list(light_direction),
                    "irradiance": irradiance}],
    }


def test_shadowed_point_is_exactly_the_documented_shadow_tone():
    # Defaults: shadow colour 0.3, shadow factor 0.1, band softness 0.01. The highlight is made
    # wide enough to cover the whole floor, to show that it is absent in shadow.
    color, irradiance = np.array([0.9, 0.6, 0.3]), 3.0
    direction = np.array([1.0, -1.0, 0.0]) / np.sqrt(2)
    material = toon(color=color, highlight={"size": 0.5, "color": [0.2, 0.2, 0.2]})
    data = shadowed_floor(material, direction, irradiance)
    scene = clrender.load_scene_dict(data)
    result = clrender.Renderer(scene).render(spp=1, seed=1)
    assert result.discarded_samples == 0
    points, _ = centre_points(scene, result.aux)
    # Follow each floor point towards the light to the plate's plane y = 1: the plate's shadow
    # is the plate square [-1.4, -0.2] x [-0.6, 0.6] shifted by the light. Keep a 2-pixel margin
    # (pixel size 0.11 at this distance) from its edges, where the jittered sample may cross.
    on_floor = interior(result.aux["object_id"] == 0)
    to_plate = points + (-direction) * (1.0 / -direction[1])
    inside = np.maximum(np.abs(to_plate[..., 0] + 0.8), np.abs(to_plate[..., 2])) < 0.6 - 0.25
    outside = np.maximum(np.abs(to_plate[..., 0] + 0.8), np.abs(to_plate[..., 2])) > 0.6 + 0.25
    shadowed, lit = on_floor & inside, on_floor & outside
    assert shadowed.sum() > 30 and lit.sum() > 300
    cos_light = -direction[1]  # > softness: the band is fully on
    assert cos_light > 0.01
    expected_shadow = color * irradiance * INV_PI * (0.3 + (1 - 0.3) * 0.1)
    np.testing.assert_allclose(result.image[shadowed], np.broadcast_to(expected_shadow, (shadowed.sum(), 3)),
                               rtol=1e-6)
    # Lit: the full tone plus the highlight (N.H >= cos 22.5 deg > 1 - 0.5 everywhere here).
    expected_lit = (color + 0.2) * irradiance * INV_PI
    np.testing.assert_allclose(result.image[lit], np.broadcast_to(expected_lit, (lit.sum(), 3)), rtol=1e-6)


def test_rim_appears_only_where_the_view_grazes():
    threshold, irradiance = 0.6, 2.0
    rim_blue = 0.5
    material = toon(color=[0.8, 0.5, 0.0], rim={"threshold": threshold, "width": 0.0,
                                                "color": [0, 0, rim_blue]})
    data = lit_sphere(material, (0, 0, -1), irradiance, resolution=(64, 64), smooth=True)
    scene = clrender.load_scene_dict(data)
    result = clrender.Renderer(scene).render(spp=1, seed=2)
    assert result.discarded_samples == 0
    points, view = centre_points(scene, result.aux)
    n_dot_v = np.sum(result.aux["normal"] * view, axis=-1)
    on_sphere = result.aux["object_id"] == 0
    # The jittered sample lies within half a pixel of the centre: allow the largest change of
    # N.V between neighbouring centres, and drop pixels next to the background.
    step = np.zeros_like(n_dot_v)
    for axis in (0, 1):
        diff = np.abs(np.diff(np.where(on_sphere, n_dot_v, np.nan), axis=axis))
        pad = [(0, 0), (0, 0)]
        pad[axis] = (1, 0)
        step = np.fmax(step, np.pad(diff, pad, constant_values=np.nan))
        pad[axis] = (0, 1)
        step = np.fmax(step, np.pad(diff, pad, constant_values=np.nan))
    inner = interior(on_sphere)
    blue = result.image[..., 2]
    grazing = inner & (n_dot_v < threshold - step)
    facing = inner & (n_dot_v > threshold + step)
    assert grazing.sum() > 50 and facing.sum() > 500
    assert np.all(blue[grazing] > 0)
    assert np.all(blue[facing] == 0)
    # Lit by a light from the camera: the rim is at full strength, rim colour * E / pi.
    np.testing.assert_allclose(blue[grazing].max(), rim_blue * irradiance * INV_PI, rtol=1e-6)


def test_several_lights_add_up():
    # Delta lights are evaluated all, deterministically: the sum is exact up to rounding.
    material = toon(color=[0.7, 0.6, 0.5], bands=3, highlight_size=0.05,
                    rim={"threshold": 0.2, "color": [0.1, 0.2, 0.3]})
    sun = {"type": "directional", "direction": [-1, -0.5, -1], "irradiance": [2.0, 1.5, 1.0]}
    bulb = {"type": "point", "position": [2.0, 1.0, 2.0], "intensity": 6.0}
    images = [render(lit_sphere(material, None, lights=lights), seed=7).image
              for lights in ([sun], [bulb], [sun, bulb])]
    np.testing.assert_allclose(images[2], images[0] + images[1], rtol=1e-5, atol=1e-7)
    assert np.count_nonzero(images[0]) and np.count_nonzero(images[1])


# --------------------------------------------------------------------------------------------
# Sampled lights
# --------------------------------------------------------------------------------------------
def test_area_light_gives_the_band_weighted_solid_angle():
    # A toon floor point straight under a square light of radiance Le: every direction to the
    # light has N.L > softness (band 1) and is visible, so the radiance is
    # color / pi * Le * (solid angle of the light). The camera sees a tiny patch under the light.
    half, height, le = 0.25, 1.0, 4.0
    color = np.array([0.6, 0.6, 0.6])
    data = {
        "camera": camera(position=(0, 0.5, 0), look_at=(0, 0, 0), up=(0, 0, -1), fov=0.5,
                         resolution=(16, 16)),
        "materials": [toon(color=color), {"name": "lamp", "type": "emissive", "radiance": le}],
        "shapes": [{"type": "rectangle", "material": "toon", "transform": {"rotate": [-90, 0, 0]}},
                   {"type": "rectangle", "material": "lamp",
                    "transform": {"scale": half, "rotate": [90, 0, 0], "translate": [0, height, 0]}}],
    }
    result = render(data, spp=16, seed=5)
    solid_angle = 4 * np.arcsin(half * half / (half * half + height * height))
    expected = color[0] * INV_PI * le * solid_angle
    # The camera at y = 0.5 sits below the light: it hides a little of it. Its shadow ray is
    # never blocked: the camera is not geometry. Every pixel is the same point to < 1e-5.
    assert z_bound(result.image[..., 0], expected) < 5.0


def test_uniform_environment_on_a_convex_toon_object():
    # Flat facets of a convex object: directions above a facet are all visible. Per pixel the
    # expectation is color * Le * [4 S + 2 (1 - S)(1 - softness / 2)]: the shadow tone from the
    # whole sphere of directions (added exactly), the lit tone from the facet's hemisphere
    # (sampled), the smoothstep edge integrating to softness / 2.
    le, shadow, softness = 0.7, 0.2, 0.3
    color = np.array([0.5, 0.4, 0.3])
    data = {
        "camera": camera(fov=30),
        "materials": [toon(color=color, shadow_color=shadow, softness=softness)],
        "shapes": [{"type": "sphere", "mesh": True, "material": "toon", "radius": 1.0, "subdivisions": 3,
                    "smooth": False}],
        "lights": [{"type": "environment", "radiance": le}],
        "render": {"max_depth": 4},
    }
    coverage = render(data, spp=64, seed=9, max_depth=1).image
    result = render(data, spp=64, seed=9)
    covered = coverage[..., 0] == 0  # every camera ray of the pixel hit the sphere
    assert covered.sum() > 200
    background = coverage[..., 0] == le  # every camera ray escaped
    assert np.all(result.image[background] == le)
    factor = 4 * shadow + 2 * (1 - shadow) * (1 - softness / 2)
    for channel in range(3):
        assert z_bound(result.image[covered][:, channel], color[channel] * le * factor) < 5.0


def test_image_environment_on_a_toon_floor(tmp_path):
    # An upward floor seen from above, crisp band: expectation color / pi * [S * (integral of Le
    # over the sphere) + (1 - S) * (integral over the upper hemisphere)], both exact sums over
    # the piecewise-constant lat-long texels.
    from test_lights import environment_image

    image = environment_image()
    clrender.save_image(image, tmp_path / "sky.exr")
    shadow, color = 0.3, np.array([0.8, 0.6, 0.4])
    data = {
        "camera": camera(position=(0, 2, 0), look_at=(0, 0, 0), up=(0, 0, -1), fov=20, resolution=(24, 24)),
        "materials": [toon(color=color, shadow_color=shadow, softness=0.0)],
        "shapes": [{"type": "rectangle", "material": "toon", "transform": {"rotate": [-90, 0, 0]}}],
        "lights": [{"type": "environment", "file": "sky.exr"}],
    }
    result = clrender.Renderer(clrender.load_scene_dict(data, base_dir=tmp_path)).render(spp=64, seed=4)
    assert result.discarded_samples == 0
    height, width, _ = image.shape
    cos_theta = np.cos(np.linspace(0, np.pi, height + 1))
    texel_solid_angle = (cos_theta[:-1] - cos_theta[1:]) * 2 * np.pi / width
    whole = np.einsum("hwc,h->c", image, texel_solid_angle)
    upper = np.einsum("hwc,h->c", image[:height // 2], texel_solid_angle[:height // 2])
    expected = color * INV_PI * (shadow * whole + (1 - shadow) * upper)
    for channel in range(3):
        assert z_bound(result.image[..., channel], expected[channel]) < 5.0


# --------------------------------------------------------------------------------------------
# Inside the path tracer: any vertex that hits toon adds throughput * toon radiance and stops
# --------------------------------------------------------------------------------------------
def toon_enclosure(max_depth):
    """A diffuse ball inside a closed toon sphere; a directional light outside, occluded from
    every inner point. With shadow factor 0 and no rim the toon radiance of the enclosure is the
    constant T = color * S * E / pi (the highlight needs a visible light)."""
    return {
        "camera": camera(position=(0, 0, 3.2), look_at=(0, 0, 0), fov=50),
        "materials": [toon(name="dome", color=[0.9, 0.8, 0.7], shadow_color=[0.5, 0.25, 0.125],
                           shadow_factor=0.0, highlight_size=0.3),
                      {"name": "ball", "type": "diffuse", "albedo": [0.6, 0.5, 0.4]}],
        "shapes": [{"type": "sphere", "mesh": True, "material": "dome", "radius": 4.0, "subdivisions": 2,
                    "smooth": False, "flip_normals": True},
                   {"type": "sphere", "mesh": True, "material": "ball", "radius": 1.0, "subdivisions": 3,
                    "smooth": False}],
        "lights": [{"type": "directional", "direction": [0.3, -1, 0.2], "irradiance": 2.0}],
        "render": {"max_depth": max_depth, "rr_depth": 100},
    }


def test_toon_seen_after_a_bounce_gives_throughput_times_toon_radiance():
    toon_radiance = np.array([0.9, 0.8, 0.7]) * [0.5, 0.25, 0.125] * 2.0 * INV_PI
    result = render(toon_enclosure(max_depth=3), spp=2)
    ball = result.aux["object_id"] == 1
    dome = result.aux["object_id"] == 0
    assert ball.sum() > 100 and dome.sum() > 100
    # Depth 1 (camera -> toon) and depth 2 (camera -> diffuse -> toon): the cosine-sampled
    # bounce has weight albedo exactly, the ball's own light sample is occluded, the path ends
    # at the toon vertex. Pixels straddling both take a mix of the two values.
    at_dome = np.all(np.isclose(result.image, toon_radiance, rtol=1e-6, atol=0), axis=-1)
    at_ball = np.all(np.isclose(result.image, toon_radiance * [0.6, 0.5, 0.4], rtol=1e-6, atol=0), axis=-1)
    assert np.all(at_ball[interior(ball)]) and np.all(at_dome[interior(dome)])
    assert np.sum(~(at_dome | at_ball)) <= 60  # silhouette pixels whose two samples saw both


def test_toon_radiance_counts_as_direct_lighting_for_max_depth():
    # max_depth 1: emission only, so even the camera sees no toon radiance; max_depth 2: the
    # camera sees toon, the bounce off the ball does not reach it.
    assert not np.any(render(toon_enclosure(max_depth=1)).image)
    result = render(toon_enclosure(max_depth=2))
    assert not np.any(result.image[interior(result.aux["object_id"] == 1)])
    assert np.all(result.image[interior(result.aux["object_id"] == 0)].max(axis=1) > 0)


def test_physical_surfaces_next_to_toon_objects_render():
    # Mixed scene: a toon ball on a diffuse floor under an area light; the floor receives the
    # ball's shadow and no sample is lost.
    data = {
        "camera": camera(position=(0, 2, 4), look_at=(0, 0.3, 0), fov=40, resolution=(32, 32)),
        "materials": [toon(color=[0.2, 0.5, 0.9]),
                      {"name": "floor", "type": "diffuse", "albedo": [0.7, 0.7, 0.7]},
                      {"name": "lamp", "type": "emissive", "radiance": 6.0}],
        "shapes": [{"type": "sphere", "material": "toon", "radius": 0.5, "center": [0, 0.5, 0]},
                   {"type": "rectangle", "material": "floor", "transform": {"scale": 3, "rotate": [-90, 0, 0]}},
                   {"type": "rectangle", "material": "lamp",
                    "transform": {"scale": 0.5, "rotate": [90, 0, 0], "translate": [0, 3, 0]}}],
    }
    result = render(data, spp=8)
    ball = result.aux["object_id"] == 0
    assert np.all(result.image[ball].sum(axis=1) > 0)
    assert np.all(np.isfinite(result.image))


# --------------------------------------------------------------------------------------------
# Scene data
# --------------------------------------------------------------------------------------------
def test_toon_parameters_reach_the_material_array():
    data = lit_sphere(toon(color=[0.1, 0.2, 0.3], bands=3, softness=0.05, shadow_color=[0.4, 0.5, 0.6],
                           shadow_factor=0.25, highlight={"size": 0.04, "softness": 0.02, "color": 0.7},
                           rim={"threshold": 0.3, "width": 0.1, "color": [0.9, 0.8, 0.7]}), (0, 0, -1))
    scene = clrender.load_scene_dict(data)
    record = build_scene_arrays(scene).materials[0]
    assert record["kind"][0] == clrender.layout.MATERIAL_KINDS["toon"]
    np.testing.assert_allclose(record["color"][:3], [0.1, 0.2, 0.3])
    np.testing.assert_allclose(record["toon_shadow"], [0.4, 0.5, 0.6, 0.25])
    np.testing.assert_allclose(record["toon_bands"], [3, 0.05, 0.04, 0.02])
    np.testing.assert_allclose(record["toon_highlight"], [0.7, 0.7, 0.7, 0.1])
    np.testing.assert_allclose(record["toon_rim"], [0.9, 0.8, 0.7, 0.3])
    assert scene_features(scene)["TOON"] == 1


def test_toon_defaults_are_the_documented_ones():
    material = clrender.load_scene_dict(lit_sphere({"name": "t", "type": "toon"}, (0, 0, -1))).materials[0]
    t = material.toon
    assert material.albedo.tolist() == [0.8, 0.8, 0.8]
    assert (t.bands, t.softness, t.shadow_factor) == (1, 0.01, 0.1)
    assert t.shadow_color.tolist() == [0.3, 0.3, 0.3]
    assert (t.highlight_size, t.highlight_softness, t.highlight_color.tolist()) == (0.02, 0.005, [1, 1, 1])
    assert (t.rim_threshold, t.rim_width, t.rim_color.tolist()) == (0.0, 0.05, [1, 1, 1])


def test_unused_toon_material_compiles_no_toon_code():
    data = lit_sphere({"name": "d", "type": "diffuse"}, (0, 0, -1))
    data["materials"].append({"name": "t", "type": "toon"})
    assert scene_features(clrender.load_scene_dict(data))["TOON"] == 0


@pytest.mark.parametrize("patch,where,message", [
    (dict(bands=0), "materials[0].bands", "must be >= 1"),
    (dict(bands=2.5), "materials[0].bands", "must be an integer"),
    (dict(bands=33), "materials[0].bands", "must be <= 32"),
    (dict(softness=-0.1), "materials[0].softness", "must be >= 0"),
    (dict(shadow_factor=1.5), "materials[0].shadow_factor", "must be <= 1"),
    (dict(color=[1.2, 0, 0]), "materials[0].color", "<= 1 per channel"),
    (dict(shadow_color=[0.2, -0.1, 0]), "materials[0].shadow_color", "non-negative"),
    (dict(highlight={"size": -1}), "materials[0].highlight.size", "must be >= 0"),
    (dict(highlight={"sise": 0.1}), "materials[0].highlight.sise", "unknown field"),
    (dict(rim={"color": [0, 0]}), "materials[0].rim.color", "list of 3 numbers"),
    (dict(rim={"threshold": 2}), "materials[0].rim.threshold", "must be <= 1"),
    (dict(rim=3), "materials[0].rim", "must be an object"),
    (dict(albedo=[0.5, 0.5, 0.5]), "materials[0].albedo", "unknown field"),
])
def test_invalid_toon_fields_are_reported_with_their_place(patch, where, message):
    material = {"name": "t", "type": "toon"}
    material.update(patch)
    with pytest.raises(clrender.SceneError) as error:
        clrender.load_scene_dict(lit_sphere(material, (0, 0, -1)))
    text = str(error.value)
    assert text.startswith(where + ":"), text
    assert message in text, text


@pytest.mark.parametrize("path,outlined", [("scenes/toon_cornell_box.json", True),
                                           ("scenes/toon_character.json", True)])
def test_example_toon_scenes_render(path, outlined):
    scene = clrender.load_scene(path)
    assert scene_features(scene)["TOON"] == 1
    scene.camera.resolution = (32, 32)
    result = clrender.Renderer(scene).render(spp=2, seed=1)
    assert result.discarded_samples == 0
    assert np.all(np.isfinite(result.image)) and result.image.max() > 0
    assert (result.outline_alpha is not None) == outlined
    toon_ids = [i for i, shape in enumerate(scene.shapes) if scene.materials[shape.material].type == "toon"]
    assert np.isin(result.aux["object_id"], toon_ids).sum() > 20  # toon objects in view


def test_toon_object_keeps_its_tones_in_a_mirror():
    # A banded toon sphere (hard band edges, flat facets, no highlight or rim: a few exact tones)
    # seen in a tinted mirror shows exactly its directly seen tones times the tint: the path
    # reflects off the delta mirror and takes the toon radiance at the sphere.
    tint = np.array([0.9, 0.8, 0.7])
    material = toon(bands=2, softness=0.0, shadow_color=[0.3] * 3)
    sun = [{"type": "directional", "direction": [0.2, -1.0, 0.4], "irradiance": 2.0}]
    sphere = {"type": "sphere", "mesh": True, "material": "toon", "center": [4, 0, 4], "radius": 1.0,
              "subdivisions": 3, "smooth": False}
    mirror = {"type": "rectangle", "material": "mirror", "transform": {"scale": 3}}
    seen_in_mirror = render({
        "camera": camera(position=(-4, 0, 4), look_at=(0, 0, 0), fov=20, resolution=(48, 48)),
        "materials": [material, {"name": "mirror", "type": "conductor", "tint": tint.tolist()}],
        "shapes": [sphere, mirror], "lights": sun}, max_depth=3)
    seen_directly = render({   # from the camera's mirror image, without the mirror
        "camera": camera(position=(-4, 0, -4), look_at=(0, 0, 0), fov=20, resolution=(48, 48)),
        "materials": [material], "shapes": [sphere], "lights": sun}, max_depth=3)
    direct_tones = np.unique(seen_directly.image[seen_directly.image[..., 0] > 0], axis=0)
    mirror_tones = np.unique(seen_in_mirror.image[seen_in_mirror.image[..., 0] > 0], axis=0)
    assert len(direct_tones) == 3  # shadow tone and two bands
    np.testing.assert_allclose(mirror_tones, direct_tones * tint, rtol=1e-5)
