"""A small scene for every feature combination, exercising the code each feature compiles in.

Used where every combination must run, not only compile: the Oclgrind checks of every memory
access (tests/test_oclgrind.py) and the kernel figures of `clrender info --kernel`. The scene
needs exactly the given features (`features.scene_features(scene, method, sample_aovs) == features`,
AOVS being what the render asks for, not a property of the scene).
"""
import numpy as np

from . import meshes
from .layout import ENVIRONMENT_MODES, VOLUME_METHODS
from .scene import load_scene_dict

_METHODS = {value: name for name, value in VOLUME_METHODS.items()}


def feature_scene(features, resolution=(8, 8), subdivisions=None):
    """(scene, volume_method) needing exactly `features` (a dict as features.scene_features
    returns). Every combination has a diffuse floor and box, two area lights (a rectangle and a
    sphere), a point, a spot and a directional light, seen through a thin lens with the gaussian
    pixel filter; each feature adds what it compiles in:
    ENVIRONMENT constant or image (a procedural lat-long map with a bright sun, tilted, looked up
    as Mitsuba's envmap); DIELECTRIC smooth
    glass reflecting tinted, rough Beckmann glass and a rough GGX mirror (energy tables), a
    smooth copper mirror (complex Fresnel), a thin dielectric pane, a smooth plastic and a rough
    one (coat tables), a principled sphere (every lobe, transmission included); TOON a toon sphere;
    MEDIA a fog sphere (index-matched boundary) and, with DIELECTRIC, tinted glass holding a
    medium; GRID_MEDIA a procedural cloud in a box overlapping the fog, so paths cross both
    kinds of media; TEXTURES a checkerboard floor, an 8-bit sRGB bitmap on the box (mirrored
    repeats), a textured emitting sphere, a leaf-like panel masked by a bitmap, a bump-mapped and
    a normal-mapped sphere, a card with different front and back materials, and with DIELECTRIC
    float bitmaps driving the rough mirror's roughness, the rough plastic's (rows of coat
    tables) and the principled sphere's anisotropy (its tangents need dp/du), the sRGB bitmap the
    plastic's diffuse reflectance, the checkerboard the principled metallic (the card's back then
    a rough mirror). The
    spheres are analytic (they share BVH leaves with the triangles), or
    icospheres of level `subdivisions` (0..7) when it is given. Packets (LANES 8) cover fewer
    materials (features.packets_cover): with DIELECTRIC their scene has the smooth glass, the
    copper mirror, two rough mirrors without energy compensation (Beckmann with separable
    masking, as Mitsuba's scenes have them, and GGX) and the two plastics; with TEXTURES only
    colours (the floor's, the box's and the plastics') and the leaf's opacity come from textures;
    it needs its features when the renderer asks for packets."""
    materials = [{"name": "white", "type": "diffuse", "albedo": [0.7, 0.7, 0.6]},
                 {"name": "lamp", "type": "emissive", "radiance": [6.0, 5.0, 4.0]}]
    shapes = [{"name": "floor", "type": "rectangle", "material": "white",
               "transform": {"scale": 3, "rotate": [-90, 0, 0], "translate": [0, -1, 0]}},
              {"name": "block", "type": "box", "material": "white",
               "transform": {"scale": 0.3, "rotate": [0, 30, 0], "translate": [-1.2, -0.7, -0.5]}},
              {"name": "lamp", "type": "rectangle", "material": "lamp",
               "transform": {"scale": 0.4, "rotate": [90, 0, 0], "translate": [0, 1.5, 0]}}]
    lights = [{"type": "point", "position": [1.5, 1.2, 1.5], "intensity": 2.0},
              {"type": "spot", "position": [-1.0, 1.5, 1.0], "direction": [0.4, -1, -0.3], "intensity": 6.0,
               "cutoff_angle": 30},
              {"type": "directional", "direction": [-0.3, -1, -0.4], "irradiance": 1.0}]
    media = []

    def sphere(name, material, center, radius, **extra):
        tessellation = {} if subdivisions is None else {"mesh": True, "subdivisions": subdivisions}
        shapes.append({"name": name, "type": "sphere", "material": material, "center": center,
                       "radius": radius, **tessellation, **extra})

    packets = features.get("LANES", 1) > 1
    sphere("bulb", "lamp", [1.3, 0.9, -0.9], 0.15)
    if features["ENVIRONMENT"] != ENVIRONMENT_MODES["none"]:
        lights.append({"type": "environment", "radiance": [0.3, 0.4, 0.5]})
    if features["DIELECTRIC"] and packets:
        materials += [{"name": "glass", "type": "dielectric", "ior": 1.5},
                      {"name": "mirror", "type": "conductor", "material": "Cu"},
                      {"name": "rough_mirror", "type": "conductor", "material": "Au", "roughness": 0.3,
                       "distribution": "beckmann", "masking": "separable", "energy_compensation": False},
                      {"name": "rough_tint", "type": "conductor", "tint": [0.9, 0.7, 0.5], "roughness": 0.2,
                       "energy_compensation": False}]
        sphere("glass", "glass", [0.9, -0.5, 0.3], 0.45)
        shapes.append({"name": "mirror", "type": "rectangle", "material": "mirror",
                       "transform": {"scale": 0.4, "rotate": [0, 60, 0], "translate": [-1.6, -0.4, 0.2]}})
        shapes.append({"name": "rough_mirror", "type": "box", "material": "rough_mirror",
                       "transform": {"scale": [0.6, 0.5, 0.05], "translate": [0.3, -0.5, -1.2]}})
        sphere("rough_tint", "rough_tint", [-0.45, -0.75, 1.6], 0.25)
        shapes.append({"name": "prism", "type": "box", "material": "glass",
                       "transform": {"scale": 0.3, "rotate": [20, 40, 0], "translate": [-0.2, -0.6, 0.9]}})
        materials += [{"name": "plastic", "type": "plastic", "diffuse": [0.8, 0.3, 0.2]},
                      {"name": "rough_plastic", "type": "plastic", "alpha": 0.15, "distribution": "beckmann",
                       "nonlinear": True, "diffuse": [0.2, 0.4, 0.7]}]
        sphere("plastic", "plastic", [0.6, -0.8, 1.6], 0.2)
        sphere("rough_plastic", "rough_plastic", [-0.9, -0.7, 1.2], 0.3)
    elif features["DIELECTRIC"]:
        materials += [{"name": "glass", "type": "dielectric", "ior": 1.5, "reflection_tint": [0.9, 0.95, 1.0]},
                      {"name": "rough_glass", "type": "dielectric", "ior": 1.33, "roughness": 0.4,
                       "distribution": "beckmann"},
                      {"name": "rough_mirror", "type": "conductor", "tint": [0.9, 0.7, 0.5], "roughness": 0.3},
                      {"name": "mirror", "type": "conductor", "material": "Cu"},
                      {"name": "pane", "type": "thin_dielectric", "ior": 1.5, "tint": [0.8, 0.9, 1.0]},
                      {"name": "plastic", "type": "plastic", "diffuse": [0.8, 0.3, 0.2]},
                      {"name": "rough_plastic", "type": "plastic", "alpha": 0.15, "distribution": "beckmann",
                       "nonlinear": True, "diffuse": [0.2, 0.4, 0.7]},
                      {"name": "principled", "type": "principled", "base_color": [0.3, 0.6, 0.9], "roughness": 0.4,
                       "metallic": 0.3, "spec_trans": 0.4, "spec_tint": 0.5, "sheen": 0.6, "sheen_tint": 0.5,
                       "clearcoat": 0.5, "flatness": 0.3, "specular": 0.6}]
        sphere("glass", "glass", [0.9, -0.5, 0.3], 0.45)
        sphere("principled", "principled", [-0.45, -0.75, 1.6], 0.25)
        sphere("rough_glass", "rough_glass", [-0.2, -0.6, 0.9], 0.35)
        shapes.append({"name": "rough_mirror", "type": "box", "material": "rough_mirror",
                       "transform": {"scale": [0.6, 0.5, 0.05], "translate": [0.3, -0.5, -1.2]}})
        shapes.append({"name": "mirror", "type": "rectangle", "material": "mirror",
                       "transform": {"scale": 0.4, "rotate": [0, 60, 0], "translate": [-1.6, -0.4, 0.2]}})
        shapes.append({"name": "pane", "type": "rectangle", "material": "pane",
                       "transform": {"scale": [0.5, 0.4, 1], "rotate": [0, -30, 0], "translate": [1.2, -0.5, 1.2]}})
        sphere("plastic", "plastic", [0.2, -0.75, 1.4], 0.25)
        sphere("rough_plastic", "rough_plastic", [-0.9, -0.7, 1.2], 0.3)
    textures = []
    if features["TEXTURES"] and packets:
        _add_colour_textures(textures, materials, shapes, features["DIELECTRIC"])
    elif features["TEXTURES"]:
        _add_textures(textures, materials, shapes, sphere, features["DIELECTRIC"])
    if features["TOON"]:
        materials.append({"name": "toon", "type": "toon", "color": [0.9, 0.4, 0.2]})
        sphere("toon", "toon", [-0.5, -0.6, 0.0], 0.4)
    if features["MEDIA"]:
        materials.append({"name": "boundary", "type": "interface"})
        media.append({"name": "fog", "sigma_t": [0.8, 1.2, 1.8], "albedo": 0.8, "g": 0.4})
        sphere("fog", "boundary", [0.3, 0.2, 0.0], 0.7, interior="fog")
        if features["DIELECTRIC"]:
            media.append({"name": "ink", "sigma_a": [0.5, 2.0, 4.0]})
            materials.append({"name": "tinted_glass", "type": "dielectric", "ior": 1.4})
            sphere("tinted_glass", "tinted_glass", [1.3, 0.6, -0.4], 0.35, interior="ink")
    if features["GRID_MEDIA"]:
        media.append({"name": "cloud", "type": "grid", "sigma_t": [4.0, 5.0, 6.0], "albedo": 0.9, "g": 0.5,
                      "density": {"procedural": "noise_cloud", "resolution": [6, 5, 6], "seed": 3},
                      "transform": {"scale": 1.2, "translate": [-0.9, -0.4, -0.6]}, "majorant_block": 2})
        # Overlaps the fog sphere: the cloud's exterior inside the sphere is the fog.
        shapes.append({"name": "cloud", "type": "box", "material": "boundary", "interior": "cloud",
                       "transform": {"scale": 0.6, "translate": [-0.3, 0.2, 0.0]}})
    data = {"camera": {"position": [0, 0.6, 4.5], "look_at": [0, -0.2, 0], "fov": 45,
                       "resolution": list(resolution), "filter": {"type": "gaussian"}, "aperture_radius": 0.05},
            "render": {"max_depth": 4, "rr_depth": 2},   # marching at its default step, 2 voxels
            "materials": materials, "shapes": shapes, "lights": lights, "media": media, "textures": textures}
    scene = load_scene_dict(data)
    if features["ENVIRONMENT"] == ENVIRONMENT_MODES["image"]:
        # Mitsuba's lookup (bilinear: it reads the next row and column) in a tilted frame.
        scene.environment.image = _sky(16, 8)
        scene.environment.lookup = "mitsuba"
        scene.environment.rotation = meshes.transform_matrix(rotate=[25, 70, 0])[:3, :3]
    method = _METHODS[features["GRID_MEDIA"]] if features["GRID_MEDIA"] else None
    return scene, method


def _add_colour_textures(textures, materials, shapes, dielectric):
    """Textures on colours and opacity alone, as packets take them: the floor (a checkerboard),
    the box (an 8-bit sRGB bitmap, mirrored beyond [0, 1]) and the masked leaf; with `dielectric`,
    the plastics' diffuse reflectance (the sRGB bitmap on the smooth plastic sphere, the
    checkerboard on the rough)."""
    rng = np.random.default_rng(7)
    textures += [{"name": "checks", "type": "checkerboard", "to_uv": [[4, 0, 0], [0, 4, 0.5]]},
                 {"name": "painted", "type": "bitmap", "wrap": "mirror", "to_uv": [[3, 0, -1], [0, 2.5, -0.7]],
                  "image": rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)}]
    materials += [{"name": "checked", "type": "diffuse", "albedo": {"texture": "checks"}},
                  {"name": "painted", "type": "diffuse", "albedo": {"texture": "painted"}}]
    shapes[0]["material"], shapes[1]["material"] = "checked", "painted"
    _add_masked_leaf(textures, materials, shapes, rng)
    if dielectric:
        next(m for m in materials if m["name"] == "plastic")["diffuse"] = {"texture": "painted"}
        next(m for m in materials if m["name"] == "rough_plastic")["diffuse"] = {"texture": "checks"}


def _add_textures(textures, materials, shapes, sphere, dielectric):
    """A textured floor (checkerboard), box (sRGB bitmap, mirrored beyond [0, 1]) and emitting
    sphere (grey float bitmap); with `dielectric`, the rough mirror's and the rough plastic's alpha
    from bitmaps, the plastic's diffuse reflectance from the sRGB one, the principled sphere's anisotropy and metallic."""
    rng = np.random.default_rng(7)
    textures += [{"name": "checks", "type": "checkerboard", "to_uv": [[4, 0, 0], [0, 4, 0.5]]},
                 {"name": "painted", "type": "bitmap", "wrap": "mirror", "to_uv": [[3, 0, -1], [0, 2.5, -0.7]],
                  "image": rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)},
                 {"name": "glow", "type": "bitmap", "filter": "nearest", "wrap": "clamp",
                  "image": rng.uniform(1, 8, (4, 6)).astype(np.float32)}]
    materials += [{"name": "checked", "type": "diffuse", "albedo": {"texture": "checks"}},
                  {"name": "painted", "type": "diffuse", "albedo": {"texture": "painted"}},
                  {"name": "glowing", "type": "emissive", "radiance": {"texture": "glow"}}]
    shapes[0]["material"], shapes[1]["material"] = "checked", "painted"
    sphere("glowing", "glowing", [-1.3, 0.8, -0.6], 0.2, transform={"rotate": [30, 0, 10]})
    _add_surface_wrappers(textures, materials, shapes, sphere, rng, dielectric)
    if dielectric:
        textures.append({"name": "bumps", "type": "bitmap", "image": rng.uniform(0.05, 0.5, (3, 3, 1)).astype(np.float32)})
        rough = next(m for m in materials if m["name"] == "rough_mirror")
        rough.pop("roughness")
        rough.update(alpha={"texture": "bumps"}, energy_compensation=False)
        textures.append({"name": "gloss", "type": "bitmap", "image": rng.uniform(0.1, 0.15, (2, 3, 1)).astype(np.float32)})
        rough_plastic = next(m for m in materials if m["name"] == "rough_plastic")
        rough_plastic.update(alpha={"texture": "gloss"}, diffuse={"texture": "painted"})
        principled = next(m for m in materials if m["name"] == "principled")
        principled.update(anisotropic={"texture": "bumps"}, metallic={"texture": "checks"})


def _add_masked_leaf(textures, materials, shapes, rng):
    """A masked panel between the rectangle light and the floor (an 8-bit opacity bitmap)."""
    textures.append({"name": "leaf_mask", "type": "bitmap", "raw": True,
                     "image": rng.integers(0, 256, (6, 5, 1), dtype=np.uint8)})
    materials.append({"name": "leaf", "type": "diffuse", "albedo": [0.2, 0.6, 0.1], "opacity": {"texture": "leaf_mask"}})
    shapes.append({"name": "leaf", "type": "rectangle", "material": "leaf",
                   "transform": {"scale": 0.5, "rotate": [80, 20, 0], "translate": [0.1, 0.9, 0.1]}})


def _add_surface_wrappers(textures, materials, shapes, sphere, rng, dielectric):
    """The masked leaf, a bump-mapped and a normal-mapped sphere, and a card whose back is
    another material."""
    _add_masked_leaf(textures, materials, shapes, rng)
    textures += [{"name": "heights", "type": "bitmap", "image": rng.uniform(0, 0.2, (5, 6)).astype(np.float32)},
                 {"name": "normals", "type": "bitmap", "raw": True,
                  "image": rng.integers(96, 256, (4, 4, 3), dtype=np.uint8)}]
    materials += [{"name": "bumpy", "type": "diffuse", "albedo": [0.6, 0.5, 0.4],
                   "bump": {"texture": "heights", "scale": 0.5}},
                  {"name": "dented", "type": "diffuse", "albedo": [0.4, 0.5, 0.6], "normal_map": {"texture": "normals"}},
                  {"name": "card_back", "type": "conductor", "tint": [0.8, 0.6, 0.4], "roughness": 0.4}
                  if dielectric else {"name": "card_back", "type": "diffuse", "albedo": [0.1, 0.3, 0.7]},
                  {"name": "card", "type": "diffuse", "albedo": [0.8, 0.2, 0.2], "back": "card_back"}]
    shapes += [{"name": "card", "type": "rectangle", "material": "card",
                "transform": {"scale": 0.35, "rotate": [0, 150, 0], "translate": [1.5, -0.5, 0.8]}}]
    sphere("bumpy", "bumpy", [-0.9, -0.7, 1.0], 0.3)
    sphere("dented", "dented", [0.6, -0.75, 1.4], 0.25)


def _sky(width, height):
    """A lat-long map: a blue gradient and a bright sun texel (importance sampling has a peak)."""
    v = (np.arange(height) + 0.5)[:, None, None] / height
    image = np.broadcast_to(np.array([0.2, 0.3, 0.6]) * (1.2 - v), (height, width, 3)).copy()
    image[1, width // 3] = [40.0, 36.0, 30.0]
    return image.astype(np.float32)

