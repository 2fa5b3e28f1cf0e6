"""Toon material: the classic cel formula with its documented parameters (docs/materials-toon.md),
light units, shadows through interface boundaries and media, bands, area and environment
lights, and the path-vertex rule (a vertex hitting toon adds throughput * toon radiance and stops).

Delta lights make toon radiance deterministic: those tests are exact (float32 rounding only).
With 1 sample per pixel every pixel value is the radiance of exactly one camera ray; where a test
needs that ray, `camera_rays` reproduces it (the kernel's counter-based jitter), so pixel values
are compared with the formula evaluated in numpy on the very ray the kernel traced.
Area lights, environments and media are sampled: those tests use the standard error (z_bound).
"""
import numpy as np
import pytest

import clrender
from clrender.arrays import build_scene_arrays
from clrender.bvh import intersect_brute_force
from clrender.features import scene_features
from clrender.triangle_blocks import slot_triangles
from conftest import camera, z_bound

INV_PI = 1.0 / np.pi
# Float32 rounding of N.V (~1e-6) times the slope of the default rim edge (1.5 / width = 75)
# times the rim colour: the tolerance of exact comparisons where the rim edge falls in a pixel.
RIM_ROUNDING = 2e-5

# The documented defaults of a toon material (docs/materials-toon.md).
DEFAULTS = dict(ambient=0.1, shadow_factor=0.1, shadow_color=1.0, bands=1, softness=0.01,
                highlight_size=0.02, highlight_softness=0.005, highlight_color=1.0,
                rim_threshold=0.25, rim_width=0.02, rim_color=0.5)


def toon(name="toon", color=(0.8, 0.5, 0.0), highlight_size=0.0, rim_threshold=0.0, **fields):
    """A toon material dict; the highlight and rim are off unless asked for, so that most tests
    see a few exact tones."""
    material = {"name": name, "type": "toon", "color": list(color),
                "highlight": {"size": highlight_size}, "rim": {"threshold": rim_threshold}}
    material.update(fields)
    return material


def render(data, spp=1, seed=3, **settings):
    scene = clrender.load_scene_dict(data)
    result = clrender.Renderer(scene).render(spp=spp, seed=seed, **settings)
    assert result.discarded_samples == 0
    return result


# --------------------------------------------------------------------------------------------
# The formula in numpy
# --------------------------------------------------------------------------------------------
def smoothstep(edge0, edge1, x):
    """As the kernel's toon_step: a crisp step x > edge0 when the edges coincide."""
    x = np.asarray(x, float)
    if edge1 <= edge0:
        return (x > edge0).astype(float)
    t = np.clip((x - edge0) / (edge1 - edge0), 0, 1)
    return t * t * (3 - 2 * t)


def dot(a, b):
    return np.sum(a * b, axis=-1)


def toon_reference(color, n, v, lights, **parameters):
    """The documented toon radiance at points with unit normal n and unit view direction v
    ((..., 3) arrays). lights: (l, strength, transmittance, share) per light: unit direction
    towards it (..., 3), s = irradiance / pi (rgb), T ((...) or per channel (..., 3)) and its
    power share p."""
    p = dict(DEFAULTS, **parameters)
    col = lambda key: np.broadcast_to(np.asarray(p[key], float), (3,))
    lit = np.zeros(n.shape)
    reached = np.zeros(n.shape)
    for l, strength, transmittance, share in lights:
        n_dot_l = dot(n, l)
        bands = p["bands"]
        band = sum(smoothstep(k / bands, k / bands + p["softness"], n_dot_l) for k in range(bands)) / bands
        r = 2 * n_dot_l[..., None] * n - l
        size = p["highlight_size"]
        highlight = (smoothstep(1 - size, 1 - size + p["highlight_softness"], dot(r, v)) if size > 0
                     else np.zeros(n_dot_l.shape)) * smoothstep(0, p["softness"], n_dot_l)
        t = np.asarray(transmittance, float)
        t = t if t.ndim == n.ndim else t[..., None]  # per channel, or grey
        lit += np.asarray(strength, float) * t * (band[..., None] + col("highlight_color") * highlight[..., None])
        reached += share * t
    blocked = p["shadow_factor"] * col("shadow_color")
    visibility = blocked + (1 - blocked) * reached if lights else 1.0
    rim = col("rim_color") * smoothstep(0, p["rim_width"], p["rim_threshold"] - dot(n, v))[..., None]
    return np.asarray(color, float) * (lit + visibility * (col("ambient") + rim))


# --------------------------------------------------------------------------------------------
# The kernel's camera rays, and what they hit
# --------------------------------------------------------------------------------------------
def _hash_u32(x):
    """kernels/rng.h hash_u32 on uint32 arrays."""
    x = np.asarray(x, np.uint32)
    with np.errstate(over="ignore"):
        x = x ^ (x >> np.uint32(16))
        x = x * np.uint32(0x7FEB352D)
        x = x ^ (x >> np.uint32(15))
        x = x * np.uint32(0x846CA68B)
        x = x ^ (x >> np.uint32(16))
    return x


def camera_rays(scene, seed, sample=0):
    """Origin and unit directions (H, W, 3) of the rays the kernel traces for one sample: the
    jitter is the sample's first two random numbers (kernels/rng.h, camera_ray in camera.h) of
    the independent sampler, which the renders compared with these rays use."""
    width, height = scene.camera.resolution
    pixel = np.arange(width * height, dtype=np.uint32)
    key = _hash_u32(pixel ^ _hash_u32(np.uint32(sample) ^ _hash_u32(np.uint32(seed) ^ np.uint32(0x5BD1E995))))
    with np.errstate(over="ignore"):
        jitter = [(_hash_u32(key + np.uint32(c) * np.uint32(0x9E3779B9)) >> np.uint32(8)).astype(np.float32)
                  * np.float32(2.0 ** -24) for c in (0, 1)]
    x = (pixel % width).astype(np.float32) + jitter[0]
    y = (pixel // width).astype(np.float32) + jitter[1]
    sx = np.float32(2) * x / np.float32(width) - np.float32(1)
    sy = np.float32(1) - np.float32(2) * y / np.float32(height)
    forward, right, up = (v.astype(np.float32) for v in scene.camera.basis())
    d = forward + sx[:, None] * right + sy[:, None] * up
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    return scene.camera.position, d.reshape(height, width, 3).astype(float)


class Hits:
    """First hits of rays against the scene's triangles (brute force, float64), or only those of
    the shapes in `objects`: object id (-1: miss), hit point (the origin for a miss), unit
    geometric normal facing the ray and the smallest barycentric coordinate of the hit."""

    def __init__(self, arrays, origin, directions, objects=None):
        keep = np.ones(len(arrays.info), bool) if objects is None else np.isin(arrays.info["info"][:, 1], objects)
        v0, e1, e2 = (x[keep].astype(float) for x in slot_triangles(arrays.blocks, len(arrays.info)))
        shape = directions.shape[:-1]
        d = directions.reshape(-1, 3)
        o = np.broadcast_to(origin, d.shape)
        t, prim = intersect_brute_force(v0, v0 + e1, v0 + e2, o, d)
        hit = prim >= 0
        safe = np.where(hit, prim, 0)
        self.object = np.where(hit, arrays.info["info"][keep][safe, 1], -1).reshape(shape)
        self.point = (o + np.where(hit, t, 0).astype(float)[:, None] * d).reshape(directions.shape)
        n = np.cross(e1[safe], e2[safe])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        n *= -np.sign(dot(n, d))[:, None]
        self.normal = n.reshape(directions.shape)
        # Barycentrics of the hit: pixels whose ray passes next to an edge are ambiguous.
        q = self.point.reshape(-1, 3) - v0[safe]
        a, b, c = dot(e1[safe], e1[safe]), dot(e1[safe], e2[safe]), dot(e2[safe], e2[safe])
        qa, qb = dot(q, e1[safe]), dot(q, e2[safe])
        det = a * c - b * b
        b1, b2 = (c * qa - b * qb) / det, (a * qb - b * qa) / det
        self.edge = np.where(hit, np.minimum(np.minimum(b1, b2), 1 - b1 - b2), -1.0).reshape(shape)


def blocked_towards(arrays, points, normals, direction, objects, margin=1e-3):
    """(blocked, certain): whether a ray from each point towards `direction` hits one of the
    shapes `objects`, and whether rays from points `margin` away along the surface agree (away
    from shadow edges)."""
    keep = np.isin(arrays.info["info"][:, 1], objects)
    v0, e1, e2 = (x[keep].astype(float) for x in slot_triangles(arrays.blocks, len(arrays.info)))
    p = points.reshape(-1, 3) + 1e-5 * normals.reshape(-1, 3)
    d = np.broadcast_to(direction, p.shape)
    tangent = np.cross(normals.reshape(-1, 3), [0.3, 0.5, 0.8])
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    bitangent = np.cross(normals.reshape(-1, 3), tangent)
    results = [intersect_brute_force(v0, v0 + e1, v0 + e2, p + s * margin * axis, d)[1] >= 0
               for s, axis in ((0, tangent), (1, tangent), (-1, tangent), (1, bitangent), (-1, bitangent))]
    blocked = results[0]
    certain = np.all([r == blocked for r in results], axis=0)
    return blocked.reshape(points.shape[:-1]), certain.reshape(points.shape[:-1])


# --------------------------------------------------------------------------------------------
# The formula, closed form
# --------------------------------------------------------------------------------------------
def formula_sphere(material, to_light, irradiance=np.pi, occluder=True):
    """A flat-faceted toon sphere seen straight on, a directional light, and a black plate
    between them that shadows part of the lit side (out of the camera's view)."""
    shapes = [{"type": "sphere", "mesh": True, "material": "toon", "radius": 1.0, "subdivisions": 4, "smooth": False}]
    if occluder:
        centre = 2.2 * np.asarray(to_light) + [0.15, -0.45, 0.0]
        shapes.append({"type": "rectangle", "material": "black",
                       "transform": {"scale": 0.35, "rotate": [0, 90, 0], "translate": centre.tolist()}})
    return {
        "camera": camera(position=(0, 0, 5), look_at=(0, 0, 0), fov=26, resolution=(48, 48)),
        "materials": [material, {"name": "black", "type": "diffuse", "albedo": [0, 0, 0]}],
        "shapes": shapes,
        "lights": [{"type": "directional", "direction": (-np.asarray(to_light)).tolist(),
                    "irradiance": irradiance}],
    }


def terminator_light():
    """A direction towards the light that puts one facet facing the camera at N.L = 0.005,
    inside the smoothstep of the default terminator; the lit side faces the upper left."""
    mesh = clrender.meshes.icosphere(radius=1.0, subdivisions=4, smooth=False)
    corners = mesh.vertices[mesh.faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    facet = normals[np.argmax(normals @ np.array([0.45, -0.2, 0.87]))]
    side = np.array([-0.8, 0.5, 0.33])
    side -= (side @ facet) * facet
    side /= np.linalg.norm(side)
    return 0.005 * facet + np.sqrt(1 - 0.005 ** 2) * side


FORMULA_PARAMETERS = [
    {},  # the defaults: the formula exactly
    dict(ambient=[0.2, 0.3, 0.1], shadow_factor=0.3, shadow_color=[0.5, 0.7, 1.0], bands=3, softness=0.05,
         highlight_size=0.1, highlight_softness=0.02, highlight_color=[0.6, 0.8, 1.0],
         rim_threshold=0.35, rim_width=0.1, rim_color=[0.9, 0.4, 0.2]),
]


def material_from(parameters, color):
    """A toon material dict from reference-style parameter names."""
    p = dict(DEFAULTS, **parameters)
    return {"name": "toon", "type": "toon", "color": list(color), "ambient": p["ambient"],
            "shadow_factor": p["shadow_factor"], "shadow_color": p["shadow_color"], "bands": p["bands"],
            "softness": p["softness"],
            "highlight": {"size": p["highlight_size"], "softness": p["highlight_softness"],
                          "color": p["highlight_color"]},
            "rim": {"threshold": p["rim_threshold"], "width": p["rim_width"], "color": p["rim_color"]}}


@pytest.mark.parametrize("parameters", FORMULA_PARAMETERS, ids=["defaults", "extended"])
def test_pixels_equal_the_formula(parameters):
    # Lit, terminator, cast shadow, dark side, rim and highlight pixels of one image: each pixel
    # is one camera ray, reproduced here, so the formula is evaluated where the kernel shaded.
    # A unit-strength light (irradiance pi) gives the formula's numbers.
    color = np.array([0.9, 0.6, 0.3])
    to_light = terminator_light()
    data = formula_sphere(material_from(parameters, color), to_light)
    scene = clrender.load_scene_dict(data)
    result = clrender.Renderer(scene, sampler="independent").render(spp=1, seed=11)
    assert result.discarded_samples == 0
    arrays = build_scene_arrays(scene)
    origin, directions = camera_rays(scene, seed=11)
    hits = Hits(arrays, origin, directions)
    n, view = hits.normal, -directions
    # Lit facets of a convex polyhedron do not shadow each other: only the plate can block.
    blocked, certain = blocked_towards(arrays, hits.point, n, to_light, objects=[1])
    below = dot(n, to_light) <= 0  # flat facets: the shading normal is the geometric one
    transmittance = np.where(below | blocked, 0.0, 1.0)
    expected = toon_reference(color, n, view, [(to_light, [1, 1, 1], transmittance, 1.0)], **parameters)

    usable = (hits.object == 0) & (hits.edge > 1e-4) & certain
    np.testing.assert_allclose(result.image[usable], expected[usable], atol=1e-3, rtol=0)
    assert usable.sum() > 0.95 * (hits.object == 0).sum()

    # Every part of the formula is among the pixels checked.
    p = dict(DEFAULTS, **parameters)
    n_dot_l, n_dot_v = dot(n, to_light), dot(n, view)
    r_dot_v = dot(2 * n_dot_l[..., None] * n - to_light, view)
    plain = usable & (n_dot_v > p["rim_threshold"] + 0.05) & (r_dot_v < 1 - p["highlight_size"] - 0.05)
    parts = {
        "lit": plain & ~blocked & (n_dot_l > 0.05 + p["softness"]),
        "terminator": usable & ~blocked & (n_dot_l > 0) & (n_dot_l < p["softness"]),
        "cast shadow": plain & blocked & (n_dot_l > 0.05),
        "dark side": plain & below,
        "rim": usable & (n_dot_v < p["rim_threshold"]),
        "highlight": usable & ~blocked & (r_dot_v > 1 - p["highlight_size"]) & (n_dot_l > p["softness"]),
    }
    for name, mask in parts.items():
        assert mask.sum() >= 3, name
    # The formula's values where it is plain to read (bands 1): C (1 + ambient) lit,
    # C * 0.1 * ambient in the cast shadow and on the dark side.
    if not parameters:
        np.testing.assert_allclose(result.image[parts["lit"]], np.broadcast_to(color * 1.1, (parts["lit"].sum(), 3)),
                                   rtol=1e-5)
        shadowed = parts["cast shadow"] | parts["dark side"]
        np.testing.assert_allclose(result.image[shadowed], np.broadcast_to(color * 0.01, (shadowed.sum(), 3)),
                                   rtol=1e-5)


def test_light_blocked_everywhere_leaves_shadow_factor_times_ambient_and_rim():
    # The sphere sits on a black floor and the light shines up from below it: every toon point
    # is blocked, by the floor or by the sphere itself. The image is C * 0.1 * (ambient + rim)
    # (times the shadow colour), with no light term: exactly, pixel by pixel.
    color = np.array([0.7, 0.5, 0.9])
    parameters = dict(ambient=[0.3, 0.2, 0.4], shadow_color=[1.0, 0.8, 0.6])
    material = material_from(parameters, color)
    data = {
        "camera": camera(position=(0, 1.5, 5), look_at=(0, 1, 0), fov=30, resolution=(48, 48)),
        "materials": [material, {"name": "black", "type": "diffuse", "albedo": [0, 0, 0]}],
        "shapes": [{"type": "sphere", "mesh": True, "material": "toon", "center": [0, 1, 0], "radius": 1.0,
                    "subdivisions": 3, "smooth": False},
                   {"type": "rectangle", "material": "black", "transform": {"scale": 20, "rotate": [-90, 0, 0]}}],
        "lights": [{"type": "directional", "direction": [0.3, 1.0, -0.2], "irradiance": 5.0}],
    }
    scene = clrender.load_scene_dict(data)
    result = clrender.Renderer(scene, sampler="independent").render(spp=1, seed=5)
    origin, directions = camera_rays(scene, seed=5)
    hits = Hits(build_scene_arrays(scene), origin, directions)
    sphere = (hits.object == 0) & (hits.edge > 1e-4)
    p = dict(DEFAULTS, **parameters)
    rim = np.asarray(p["rim_color"]) * smoothstep(0, p["rim_width"], p["rim_threshold"] - dot(hits.normal, -directions))[..., None]
    expected = color * 0.1 * np.asarray(p["shadow_color"]) * (np.asarray(p["ambient"]) + rim)
    np.testing.assert_allclose(result.image[sphere], expected[sphere], rtol=1e-5, atol=RIM_ROUNDING)
    no_rim = sphere & np.all(rim == 0, axis=-1)
    assert sphere.sum() > 300 and no_rim.sum() > 100 and np.any(rim[sphere] > 0)
    np.testing.assert_allclose(result.image[no_rim], expected[no_rim], rtol=1e-6)


def test_without_lights_a_toon_object_shows_ambient_and_rim():
    # Nothing can be blocked without a light: the full colour times (ambient + rim).
    color = np.array([0.4, 0.8, 0.6])
    data = formula_sphere(material_from({}, color), terminator_light(), occluder=False)
    data["lights"] = []
    scene = clrender.load_scene_dict(data)
    result = clrender.Renderer(scene, sampler="independent").render(spp=1, seed=2)
    origin, directions = camera_rays(scene, seed=2)
    hits = Hits(build_scene_arrays(scene), origin, directions)
    sphere = (hits.object == 0) & (hits.edge > 1e-4)
    expected = toon_reference(color, hits.normal, -directions, [])
    np.testing.assert_allclose(result.image[sphere], expected[sphere], rtol=1e-5, atol=RIM_ROUNDING)


# --------------------------------------------------------------------------------------------
# Light units and several lights
# --------------------------------------------------------------------------------------------
def toon_floor(material, lights, size=3.0, plate=None, resolution=(40, 40)):
    """A toon floor (y = 0) seen from above, optionally a black plate (centre, half size) at
    y = 1 casting a shadow on it."""
    shapes = [{"type": "rectangle", "material": material["name"],
               "transform": {"scale": size, "rotate": [-90, 0, 0]}}]
    if plate is not None:
        (x, z), half = plate
        shapes.append({"type": "rectangle", "material": "black",
                       "transform": {"scale": half, "rotate": [90, 0, 0], "translate": [x, 1, z]}})
    return {
        "camera": camera(position=(0, 6, 0), look_at=(0, 0, 0), up=(0, 0, -1), fov=40, resolution=resolution),
        "materials": [material, {"name": "black", "type": "diffuse", "albedo": [0, 0, 0]}],
        "shapes": shapes,
        "lights": lights,
    }


def floor_points(scene, seed):
    origin, directions = camera_rays(scene, seed)
    hits = Hits(build_scene_arrays(scene), origin, directions)
    return hits, -directions


def test_point_light_strength_is_intensity_over_pi_distance_squared():
    # A point light of intensity I at distance d has strength I / (pi d^2) in the formula: with
    # I = pi h^2 the point straight under it is lit by a unit-strength light.
    color, height = np.array([0.8, 0.7, 0.6]), 2.5
    position = np.array([0.4, height, -0.3])
    material = material_from(dict(highlight_size=0.3), color)
    data = toon_floor(material, [{"type": "point", "position": position.tolist(), "intensity": np.pi * height ** 2}])
    scene = clrender.load_scene_dict(data)
    result = clrender.Renderer(scene, sampler="independent").render(spp=1, seed=4)
    hits, view = floor_points(scene, seed=4)
    floor = (hits.object == 0) & (hits.edge > 1e-4)
    to_light = position - hits.point
    dist2 = dot(to_light, to_light)
    strength = (np.pi * height ** 2 / (np.pi * dist2))[..., None] * np.ones(3)
    l = to_light / np.sqrt(dist2)[..., None]
    # One light: its strength varies per point, so the reference takes it per pixel.
    expected = toon_reference(color, hits.normal, view, [(l, strength, 1.0, 1.0)], highlight_size=0.3)
    np.testing.assert_allclose(result.image[floor], expected[floor], rtol=1e-4, atol=1e-6)
    under = np.linalg.norm(hits.point[..., [0, 2]] - position[[0, 2]], axis=-1) < 0.1
    assert np.any(under & floor)  # where the light is straight above: C (1 + highlight + ambient)
    np.testing.assert_allclose(result.image[under & floor], np.broadcast_to(color * 2.1, ((under & floor).sum(), 3)),
                               rtol=2e-3)


def test_several_lights_add_their_terms_and_share_the_shadow_factor():
    # Two suns on a toon floor; a plate blocks the first over part of the floor. The light terms
    # add up; ambient is counted once, dimmed by b + (1 - b) * sum_j p_j T_j with p_j the
    # lights' power shares (directional lights: proportional to their mean irradiance).
    color = np.array([0.9, 0.6, 0.3])
    parameters = dict(ambient=[0.4, 0.4, 0.4], highlight_size=0.0, rim_threshold=0.0)
    material = material_from(parameters, color)
    sun1 = np.array([1.0, -1.0, 0.0]) / np.sqrt(2)
    sun2 = np.array([-0.2, -1.0, 0.5]) / np.linalg.norm([-0.2, -1.0, 0.5])
    e1, e2 = np.array([3.0, 2.0, 1.0]), np.array([1.0, 1.0, 2.5])
    lights = [{"type": "directional", "direction": sun1.tolist(), "irradiance": e1.tolist()},
              {"type": "directional", "direction": sun2.tolist(), "irradiance": e2.tolist()}]
    data = toon_floor(material, lights, plate=((-0.8, 0.0), 0.6))
    scene = clrender.load_scene_dict(data)
    result = clrender.Renderer(scene, sampler="independent").render(spp=1, seed=1)
    arrays = build_scene_arrays(scene)
    hits, view = floor_points(scene, seed=1)
    blocked1, certain1 = blocked_towards(arrays, hits.point, hits.normal, -sun1, objects=[1])
    blocked2, certain2 = blocked_towards(arrays, hits.point, hits.normal, -sun2, objects=[1])
    share1 = e1.mean() / (e1.mean() + e2.mean())
    expected = toon_reference(color, hits.normal, view,
                              [(-sun1, e1 / np.pi, np.where(blocked1, 0.0, 1.0), share1),
                               (-sun2, e2 / np.pi, np.where(blocked2, 0.0, 1.0), 1 - share1)], **parameters)
    usable = (hits.object == 0) & (hits.edge > 1e-4) & certain1 & certain2
    assert np.sum(usable & blocked1) > 30 and np.sum(usable & ~blocked1) > 300
    np.testing.assert_allclose(result.image[usable], expected[usable], rtol=1e-5)
    # Where the first sun is blocked: C [s2 + (b + (1 - b) p2) ambient], b = 0.1.
    only1 = usable & blocked1 & ~blocked2
    shadow = color * (e2 / np.pi + (0.1 + 0.9 * (1 - share1)) * 0.4)
    assert only1.sum() > 30
    np.testing.assert_allclose(result.image[only1], np.broadcast_to(shadow, (only1.sum(), 3)), rtol=1e-5)
    # Without ambient and rim, the images of the lights alone add up to the image of both.
    dark = material_from(dict(parameters, ambient=0.0), color)
    images = [render(toon_floor(dark, chosen, plate=((-0.8, 0.0), 0.6)), seed=7).image
              for chosen in ([lights[0]], [lights[1]], lights)]
    np.testing.assert_allclose(images[2], images[0] + images[1], rtol=1e-5, atol=1e-7)


# --------------------------------------------------------------------------------------------
# Bands and softness
# --------------------------------------------------------------------------------------------
def lit_sphere(material, light_direction, irradiance=2.0, resolution=(48, 48), smooth=False, lights=None):
    return {
        "camera": camera(resolution=resolution, fov=28),
        "materials": [material],
        "shapes": [{"type": "sphere", "mesh": True, "material": material["name"], "radius": 1.0,
                    "subdivisions": 4, "smooth": smooth}],
        "lights": lights or [{"type": "directional", "direction": list(light_direction),
                              "irradiance": irradiance}],
    }


@pytest.mark.parametrize("bands", [1, 2, 4])
def test_bands_give_n_lit_tones_and_the_shadow_tone(bands):
    # Light from the side: the visible half holds every N.L in [-0.5, 1]. Flat facets keep the
    # test about the bands: on a convex polyhedron a lit facet never shadows itself.
    color, irradiance, ambient = np.array([0.8, 0.5, 0.1]), 2.0, 0.2
    material = toon(color=color, bands=bands, softness=0.0, ambient=ambient)
    result = render(lit_sphere(material, (-np.sqrt(3) / 2, 0, -0.5), irradiance))
    values = result.image[result.image[..., 0] > 0]
    levels = np.unique(values, axis=0)
    lit = [color * (irradiance * INV_PI * k / bands + ambient) for k in range(1, bands + 1)]
    expected = np.array([color * 0.1 * ambient] + lit)
    assert len(levels) == bands + 1, levels
    np.testing.assert_allclose(levels, expected, rtol=1e-6)
    for level in levels:  # each tone covers a visible area, not a stray pixel
        assert np.sum(np.all(values == level, axis=1)) >= 10


def test_band_softness_blends_between_levels():
    material = toon(bands=2, softness=0.2)
    result = render(lit_sphere(material, (-np.sqrt(3) / 2, 0, -0.5)))
    values = np.unique(result.image[result.image[..., 0] > 0][:, 0])
    assert len(values) > 10  # the soft edges take intermediate values


def test_rim_appears_only_where_the_view_grazes():
    # The same render with and without the rim (the same seed: the same camera rays) differ by
    # C * rim colour exactly where N.V < threshold: lit by a light at the camera, visibility 1.
    threshold, rim_blue = 0.6, 0.5
    color = np.array([0.8, 0.5, 0.4])
    with_rim = toon(color=color, rim={"threshold": threshold, "width": 0.0, "color": [0, 0, rim_blue]})
    images = [render(lit_sphere(material, (0, 0, -1), resolution=(64, 64), smooth=True), seed=2)
              for material in (with_rim, toon(color=color))]
    aux = images[0].aux
    difference = images[0].image - images[1].image
    centre_camera = clrender.load_scene_dict(lit_sphere(with_rim, (0, 0, -1), resolution=(64, 64))).camera
    centres = centre_camera.pixel_directions(*np.meshgrid(np.arange(64) + 0.5, np.arange(64) + 0.5))
    n_dot_v = dot(aux["normal"], -centres)  # at the pixel centres, as the aux pass traced them
    on_sphere = aux["object_id"] == 0
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
    grazing = inner & (n_dot_v < threshold - step)
    facing = inner & (n_dot_v > threshold + step)
    assert grazing.sum() > 50 and facing.sum() > 500
    np.testing.assert_allclose(difference[grazing], np.broadcast_to([0, 0, color[2] * rim_blue], (grazing.sum(), 3)),
                               rtol=1e-5, atol=1e-7)
    assert np.all(difference[facing] == 0)


def interior(mask):
    """Pixels of `mask` whose 8 neighbours are in it too: their jittered samples stay in it."""
    inner = mask.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            inner &= np.roll(np.roll(mask, dy, axis=0), dx, axis=1)
    inner[[0, -1], :] = inner[:, [0, -1]] = False
    return inner


# --------------------------------------------------------------------------------------------
# Shadow rays through interface boundaries and media
# --------------------------------------------------------------------------------------------
BUBBLE_TOON = dict(ambient=0.5)  # a large ambient: its dimming by the fog is plain to see


def toon_in_a_bubble(medium=None, resolution=(32, 32)):
    """A flat-faceted toon sphere inside an `interface` sphere of radius 1.6, lit by a sun; the
    bubble holds `medium` (or nothing)."""
    data = {
        "camera": camera(position=(0, 0, 5), look_at=(0, 0, 0), fov=40, resolution=resolution),
        "materials": [material_from(BUBBLE_TOON, (0.9, 0.6, 0.3)), {"name": "boundary", "type": "interface"}],
        "shapes": [{"type": "sphere", "mesh": True, "material": "toon", "radius": 1.0, "subdivisions": 2, "smooth": False},
                   {"type": "sphere", "mesh": True, "material": "boundary", "radius": 1.6, "subdivisions": 2, "smooth": False}],
        "lights": [{"type": "directional", "direction": [0.6, -0.5, -0.62], "irradiance": 3.0}],
    }
    if medium is not None:
        data["media"] = [dict(name="fog", **medium)]
        data["shapes"][1]["interior"] = "fog"
    return data


def test_an_interface_without_a_medium_changes_nothing():
    # Shadow rays cross the index-matched boundary: the bubble casts no shadow (it did when toon
    # shadow rays stopped at any surface: everything inside was in shadow).
    bare = toon_in_a_bubble()
    bare["shapes"].pop()
    without = render(bare, seed=4).image
    within = render(toon_in_a_bubble(), seed=4).image
    assert np.count_nonzero(without.max(axis=-1) > 0.5) > 100  # a lit side
    np.testing.assert_allclose(within, without, rtol=1e-5, atol=1e-6)


def test_fog_darkens_the_lit_side_by_its_transmittance():
    # A purely absorbing fog fills the bubble. The camera ray passes the fog with probability
    # T_cam (free-flight sampling: the sample is the toon radiance or 0); the toon point's light
    # term is scaled by T_light, and ambient and rim are dimmed by b + (1 - b) T_light. Every
    # sample's ray is reproduced, so the expected image and its variance are known exactly.
    sigma, spp, seed = 0.45, 16, 6
    data = toon_in_a_bubble({"sigma_a": sigma, "sigma_s": 0.0})
    scene = clrender.load_scene_dict(data)
    result = clrender.Renderer(scene, sampler="independent").render(spp=spp, seed=seed)
    assert result.discarded_samples == 0
    arrays = build_scene_arrays(scene)
    to_light = -np.array([0.6, -0.5, -0.62]) / np.linalg.norm([0.6, -0.5, -0.62])
    v0, e1, e2 = (x.astype(float) for x in slot_triangles(arrays.blocks, len(arrays.info)))
    bubble = arrays.info["info"][:, 1] == 1
    mean = np.zeros(result.image.shape)
    variance = np.zeros(result.image.shape)
    lit_side = np.ones(result.image.shape[:2], bool)
    for sample in range(spp):
        origin, directions = camera_rays(scene, seed, sample)
        hits = Hits(arrays, origin, directions, objects=[0])
        # The toon sphere is inside: the camera ray enters the bubble, then hits the toon sphere.
        entry, _ = intersect_brute_force(v0[bubble], (v0 + e1)[bubble], (v0 + e2)[bubble],
                                         np.broadcast_to(origin, directions.reshape(-1, 3).shape),
                                         directions.reshape(-1, 3))
        camera_path = dot(hits.point - origin, directions) - entry.reshape(directions.shape[:2])
        exit_t, _ = intersect_brute_force(v0[bubble], (v0 + e1)[bubble], (v0 + e2)[bubble],
                                          hits.point.reshape(-1, 3), np.broadcast_to(to_light, (directions[..., 0].size, 3)))
        light_path = exit_t.reshape(directions.shape[:2])
        toon_hit = hits.object == 0
        t_cam = np.where(toon_hit, np.exp(-sigma * np.where(toon_hit, camera_path, 0)), 0.0)
        t_light = np.exp(-sigma * np.where(toon_hit, light_path, 0))
        n = hits.normal
        below = dot(n, to_light) <= 0
        radiance = toon_reference([0.9, 0.6, 0.3], n, -directions,
                                  [(to_light, np.full(3, 3.0 / np.pi), np.where(below, 0.0, t_light), 1.0)],
                                  **BUBBLE_TOON)
        radiance = np.where(toon_hit[..., None], radiance, 0.0)
        mean += t_cam[..., None] * radiance / spp
        variance += t_cam[..., None] * (1 - t_cam[..., None]) * radiance ** 2 / spp ** 2
        lit_side &= toon_hit & (hits.edge > 1e-4) & (dot(n, to_light) > 0.02) & (dot(n, -directions) > 0.3)
    assert lit_side.sum() > 100
    # The fog changes the lit side by the transmittances: far from the unfogged values.
    unfogged = toon_in_a_bubble()
    clear = render(unfogged, spp=1, seed=seed).image
    assert clear[lit_side].sum() > 1.5 * mean[lit_side].sum()
    for c in range(3):
        z = (result.image[lit_side, c] - mean[lit_side, c]).sum() / np.sqrt(variance[lit_side, c].sum())
        assert abs(z) < 5.0, (c, z)


def test_fog_between_the_light_and_a_toon_floor_scales_its_terms_exactly():
    # A fog box hangs between a sun and part of a toon floor, out of the camera's way: the
    # camera rays are clear, the shadow rays cross the box (analytic transmittance), so every
    # pixel is deterministic: C [s T (band + specular) + (b + (1 - b) T)(ambient + rim)], with
    # T = exp(-sigma * (path length in the box)) computed here in closed form.
    sigma = np.array([0.3, 0.6, 1.2])
    color = np.array([0.9, 0.7, 0.5])
    parameters = dict(ambient=0.4, highlight_size=0.6, highlight_softness=0.3)
    to_light = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    data = {
        "camera": camera(position=(-3, 4, 0), look_at=(-0.5, 0, 0), fov=40, resolution=(40, 40)),
        "media": [{"name": "fog", "sigma_a": sigma.tolist(), "sigma_s": 0.0}],
        "materials": [material_from(parameters, color), {"name": "boundary", "type": "interface"}],
        "shapes": [{"type": "rectangle", "material": "toon", "transform": {"scale": 6, "rotate": [-90, 0, 0]}},
                   {"type": "box", "material": "boundary", "interior": "fog",
                    "transform": {"scale": [1, 0.5, 4], "translate": [2, 1.5, 0]}}],
        "lights": [{"type": "directional", "direction": (-to_light).tolist(), "irradiance": np.pi}],
    }
    scene = clrender.load_scene_dict(data)
    result = clrender.Renderer(scene, sampler="independent").render(spp=1, seed=8)
    assert result.discarded_samples == 0
    hits, view = floor_points(scene, seed=8)
    floor = (hits.object == 0) & (hits.edge > 1e-4)
    # From (x, 0, z) towards the light the ray is at (x + s, s, z): inside the box where
    # s in [1, 2] and x + s in [1, 3].
    x = hits.point[..., 0]
    s_in, s_out = np.maximum(1.0, 1.0 - x), np.minimum(2.0, 3.0 - x)
    length = np.sqrt(2) * np.maximum(s_out - s_in, 0.0)
    transmittance = np.exp(-sigma * length[..., None])
    expected = toon_reference(color, hits.normal, view, [(to_light, [1, 1, 1], transmittance, 1.0)], **parameters)
    partly = floor & (length > 0.2) & (length < 1.2)
    assert partly.sum() > 50 and np.sum(floor & (length == 0)) > 50
    np.testing.assert_allclose(result.image[floor], expected[floor], rtol=1e-4, atol=1e-6)


# --------------------------------------------------------------------------------------------
# Sampled lights
# --------------------------------------------------------------------------------------------
def test_area_light_gives_the_band_weighted_solid_angle():
    # A toon floor point straight under a square light of radiance Le: every direction to the
    # light has N.L > softness (band 1) and is visible, so the radiance is
    # color * (Le * (solid angle of the light) / pi + ambient). The camera sees a tiny patch.
    half, height, le, ambient = 0.25, 1.0, 4.0, 0.15
    color = np.array([0.6, 0.6, 0.6])
    data = {
        "camera": camera(position=(0, 0.5, 0), look_at=(0, 0, 0), up=(0, 0, -1), fov=0.5,
                         resolution=(16, 16)),
        "materials": [toon(color=color, ambient=ambient), {"name": "lamp", "type": "emissive", "radiance": le}],
        "shapes": [{"type": "rectangle", "material": "toon", "transform": {"rotate": [-90, 0, 0]}},
                   {"type": "rectangle", "material": "lamp",
                    "transform": {"scale": half, "rotate": [90, 0, 0], "translate": [0, height, 0]}}],
    }
    result = render(data, spp=16, seed=5)
    solid_angle = 4 * np.arcsin(half * half / (half * half + height * height))
    expected = color[0] * (INV_PI * le * solid_angle + ambient)
    # The camera at y = 0.5 sits below the light: it hides a little of it. Its shadow ray is
    # never blocked: the camera is not geometry. Every pixel is the same point to < 1e-5.
    assert z_bound(result.image[..., 0], expected) < 5.0


def test_uniform_environment_on_a_convex_toon_object():
    # Flat facets of a convex object: directions above a facet are all visible, those below are
    # blocked by the facet. Per pixel the expectation is
    #   color * [ Le * 2 (1 - softness / 2) + (b + (1 - b) / 2) * ambient ]:
    # the band integrated over the hemisphere (the smoothstep edge integrating to softness / 2)
    # divided by pi, and ambient seeing half the sky blocked.
    le, softness, ambient = 0.7, 0.3, 0.25
    color = np.array([0.5, 0.4, 0.3])
    data = {
        "camera": camera(fov=30),
        "materials": [toon(color=color, softness=softness, ambient=ambient)],
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
    factor = le * 2 * (1 - softness / 2) + (0.1 + 0.9 / 2) * ambient
    for channel in range(3):
        assert z_bound(result.image[covered][:, channel], color[channel] * factor) < 5.0


def test_image_environment_on_a_toon_floor(tmp_path):
    # An upward floor seen from above, crisp band: expectation
    #   color * [ (integral of Le over the upper hemisphere) / pi + (b + (1 - b) f) ambient ]
    # with f the luminance share of the upper hemisphere (the image is importance-sampled by
    # luminance), both exact sums over the piecewise-constant lat-long texels.
    from test_lights import environment_image

    image = environment_image()
    clrender.save_image(image, tmp_path / "sky.exr")
    ambient, color = 0.3, np.array([0.8, 0.6, 0.4])
    data = {
        "camera": camera(position=(0, 2, 0), look_at=(0, 0, 0), up=(0, 0, -1), fov=20, resolution=(24, 24)),
        "materials": [toon(color=color, softness=0.0, ambient=ambient)],
        "shapes": [{"type": "rectangle", "material": "toon", "transform": {"rotate": [-90, 0, 0]}}],
        "lights": [{"type": "environment", "file": "sky.exr"}],
    }
    result = clrender.Renderer(clrender.load_scene_dict(data, base_dir=tmp_path)).render(spp=64, seed=4)
    assert result.discarded_samples == 0
    image = clrender.load_scene_dict(data, base_dir=tmp_path).environment.image.astype(float)
    height, width, _ = image.shape
    cos_theta = np.cos(np.linspace(0, np.pi, height + 1))
    texel_solid_angle = (cos_theta[:-1] - cos_theta[1:]) * 2 * np.pi / width
    upper = np.einsum("hwc,h->c", image[:height // 2], texel_solid_angle[:height // 2])
    # Directions are drawn in proportion to luminance x sin(theta) at texel centres (arrays.py).
    weights = (image @ [0.2126, 0.7152, 0.0722]) * np.sin((np.arange(height) + 0.5) / height * np.pi)[:, None]
    share = weights[:height // 2].sum() / weights.sum()
    expected = color * (INV_PI * upper + (0.1 + 0.9 * share) * ambient)
    for channel in range(3):
        assert z_bound(result.image[..., channel], expected[channel]) < 5.0


# --------------------------------------------------------------------------------------------
# Inside the path tracer: any vertex that hits toon adds throughput * toon radiance and stops
# --------------------------------------------------------------------------------------------
def toon_enclosure(max_depth):
    """A diffuse ball inside a closed toon sphere; a directional light outside, blocked from
    every inner point. So the toon radiance of the enclosure is the constant
    color * shadow_factor * shadow_color * ambient (no rim; no highlight without the light)."""
    return {
        "camera": camera(position=(0, 0, 3.2), look_at=(0, 0, 0), fov=50),
        "materials": [toon(name="dome", color=[0.9, 0.8, 0.7], shadow_color=[1.0, 0.5, 0.25],
                           shadow_factor=0.5, ambient=[0.8, 0.8, 0.8], highlight_size=0.3),
                      {"name": "ball", "type": "diffuse", "albedo": [0.6, 0.5, 0.4]}],
        "shapes": [{"type": "sphere", "mesh": True, "material": "dome", "radius": 4.0, "subdivisions": 2,
                    "smooth": False, "flip_normals": True},
                   {"type": "sphere", "mesh": True, "material": "ball", "radius": 1.0, "subdivisions": 3,
                    "smooth": False}],
        "lights": [{"type": "directional", "direction": [0.3, -1, 0.2], "irradiance": 2.0}],
        "render": {"max_depth": max_depth, "rr_depth": 100},
    }


def test_toon_seen_after_a_bounce_gives_throughput_times_toon_radiance():
    toon_radiance = np.array([0.9, 0.8, 0.7]) * 0.5 * np.array([1.0, 0.5, 0.25]) * 0.8
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


def test_toon_object_keeps_its_tones_in_a_mirror():
    # A banded toon sphere (hard band edges, flat facets, no highlight or rim: a few exact tones)
    # seen in a tinted mirror shows exactly its directly seen tones times the tint: the path
    # reflects off the delta mirror and takes the toon radiance at the sphere.
    tint = np.array([0.9, 0.8, 0.7])
    material = toon(bands=2, softness=0.0)
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
    assert len(direct_tones) == 3  # the shadow tone and two bands
    np.testing.assert_allclose(mirror_tones, direct_tones * tint, rtol=1e-5)


# --------------------------------------------------------------------------------------------
# Scene data
# --------------------------------------------------------------------------------------------
def test_toon_parameters_reach_the_material_array():
    data = lit_sphere(toon(color=[0.1, 0.2, 0.3], bands=3, softness=0.05, shadow_color=[0.4, 0.5, 0.6],
                           shadow_factor=0.25, ambient=[0.05, 0.15, 0.25],
                           highlight={"size": 0.04, "softness": 0.02, "color": 0.7},
                           rim={"threshold": 0.3, "width": 0.1, "color": [0.9, 0.8, 0.7]}), (0, 0, -1))
    scene = clrender.load_scene_dict(data)
    record = build_scene_arrays(scene).materials[0]
    fields = {name: clrender.layout.field(record, clrender.layout.MATERIAL_FIELDS, name)
              for name in clrender.layout.MATERIAL_FIELDS}
    assert fields["kind"] == clrender.layout.MATERIAL_KINDS["toon"]
    expected = {"color": [0.1, 0.2, 0.3], "toon_shadow_color": [0.4, 0.5, 0.6], "toon_shadow_factor": 0.25,
                "toon_bands": 3, "toon_band_softness": 0.05, "toon_highlight_size": 0.04,
                "toon_highlight_softness": 0.02, "toon_highlight_color": [0.7, 0.7, 0.7], "toon_rim_width": 0.1,
                "toon_rim_color": [0.9, 0.8, 0.7], "toon_rim_threshold": 0.3, "toon_ambient": [0.05, 0.15, 0.25]}
    for name, value in expected.items():
        np.testing.assert_allclose(fields[name], value, err_msg=name)
    assert scene_features(scene)["TOON"] == 1


def test_toon_defaults_are_the_documented_ones():
    material = clrender.load_scene_dict(lit_sphere({"name": "t", "type": "toon"}, (0, 0, -1))).materials[0]
    t = material.toon
    d = DEFAULTS
    assert material.albedo.tolist() == [0.8, 0.8, 0.8]
    assert t.ambient.tolist() == [d["ambient"]] * 3
    assert (t.bands, t.softness, t.shadow_factor) == (d["bands"], d["softness"], d["shadow_factor"])
    assert t.shadow_color.tolist() == [d["shadow_color"]] * 3
    assert (t.highlight_size, t.highlight_softness) == (d["highlight_size"], d["highlight_softness"])
    assert t.highlight_color.tolist() == [d["highlight_color"]] * 3
    assert (t.rim_threshold, t.rim_width) == (d["rim_threshold"], d["rim_width"])
    assert t.rim_color.tolist() == [d["rim_color"]] * 3


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
    (dict(ambient=[0.2, -0.1, 0]), "materials[0].ambient", "non-negative"),
    (dict(ambient="grey"), "materials[0].ambient", "list of 3 numbers"),
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
