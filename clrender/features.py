"""The one place that decides which kernel features a scene needs.

The megakernel is compiled with one -D define per feature, so code a scene does not use is not
compiled. Features are deliberately coarse: each new combination costs a kernel build (about
2 s on PoCL here, and tests/test_compile.py builds them all). Small code paths are not features:
point and directional lights, for instance, are always compiled in (one untaken branch).
"""
import itertools

import numpy as np

from .arrays import active_environment
from .textures import detail_beyond_textures, lets_light_through, scene_uses_textures
from .errors import ArgumentError
from .layout import ENVIRONMENT_MODES, VOLUME_METHODS

# Every feature and the values it may take; the first value is "absent".
FEATURE_VALUES = {
    "ENVIRONMENT": tuple(ENVIRONMENT_MODES.values()),
    "MEDIA": (0, 1),
    "TOON": (0, 1),
    # Specular materials: smooth and rough dielectrics, conductors and plastics (one feature for
    # all: they share the microfacet code, and every feature doubles the combinations to build).
    "DIELECTRIC": (0, 1),
    # Grid media and how they are integrated: 0 none, 1 null-scattering path integral,
    # 2 ray marching (VOLUME_* in layout.py). Only the chosen method is compiled in.
    "GRID_MEDIA": tuple(VOLUME_METHODS.values()),
    # Sample-level AOVs (albedo, normal, colour variance: kernels/aovs.h): decided by the render
    # request, not the scene, so that colour-only renders carry none of their code.
    "AOVS": (0, 1),
    # Surface detail: uv at hits, textures driving material parameters (kernels/textures/,
    # materials/textured_params.h), masks, bump and normal maps, back materials (materials/mask.h,
    # materials/shading_maps.h).
    "TEXTURES": (0, 1),
    # Camera paths per work-item (kernels/lanes.h): 8 traces them in the vector lanes of a CPU
    # (kernels/integrator_packets.cl, 1.3-1.4x faster on PoCL: docs/performance.md) for the
    # scenes it covers (packets_cover); 1 is the megakernel, one path per work-item.
    "LANES": (1, 8),
}

# What the packet integrator (LANES 8) leaves out: every other feature. (Of TEXTURES it takes
# colours alone: packets_cover.)
PACKET_FEATURES = {"MEDIA": 0, "TOON": 0, "GRID_MEDIA": 0}

# The lights (besides emitting shapes) that the packet integrator samples.
PACKET_LIGHTS = ("environment", "point", "spot", "directional")

# The defines of the tables' program (kernels/tables.cl, clrender/energy.py): the microfacet code
# of every render program, at one path per work-item.
TABLE_FEATURES = {**{name: values[0] for name, values in FEATURE_VALUES.items()}, "DIELECTRIC": 1}

SPECULAR_MATERIALS = ("dielectric", "conductor", "thin_dielectric", "plastic", "principled")


def volume_method(scene, override=None):
    """The integration method for the scene's grid media: `override` (API/CLI) or the scene's."""
    method = override if override is not None else scene.render.volume_method
    if not isinstance(method, str) or method not in VOLUME_METHODS or method == "none":
        valid = ", ".join(m for m in VOLUME_METHODS if m != "none")
        raise ArgumentError("volume_method", f"unknown volume method {method!r}; valid: {valid}")
    return method


def scene_features(scene, volume_method_override=None, sample_aovs=False, packets=False):
    """The feature values (name -> int) that `scene` needs; `volume_method_override` replaces
    the scene's render.volume_method ("null" or "raymarch"); `sample_aovs`: whether the render
    accumulates the sample-level AOVs (clrender/aovs.py); `packets`: whether the device wants
    camera paths in packets (a CPU), which they get where the packet integrator covers the
    scene."""
    method = volume_method(scene, volume_method_override)   # checked even where unused
    # A black environment lights nothing and has no emitter (clrender/arrays.py): compiling the
    # environment code for it would read the emitter table at index -1.
    environment = active_environment(scene)
    if environment is None:
        env_mode = ENVIRONMENT_MODES["none"]
    else:
        env_mode = ENVIRONMENT_MODES["image" if environment.image is not None else "constant"]
    features = {
        "ENVIRONMENT": env_mode,
        "MEDIA": int(_uses_media(scene)),
        # Only materials some shape shows: an unused toon material cannot be hit.
        "TOON": int(any(m.type == "toon" for m in scene.used_materials())),
        # Only materials that some shape shows: an unused glass definition costs no kernel code.
        "DIELECTRIC": int(any(_is_specular(m) for m in scene.used_materials())),
        "GRID_MEDIA": VOLUME_METHODS[method] if any(m.type == "grid" for m in scene.media) else 0,
        "AOVS": int(bool(sample_aovs)),
        "TEXTURES": int(scene_uses_textures(scene)),
        "LANES": 1,
    }
    if packets and packets_cover(scene, features):
        features["LANES"] = 8
    return features


def gather_features(packets, sample_aovs=False):
    """The defines of splatting's gather and the sum of sample items (kernels/splat.cl): LANES
    pixels of a row per work-item, 8 where the device wants camera paths in packets (a CPU), else
    1; AOVS where sample items' sums take the sample-level AOVs too."""
    return {"LANES": FEATURE_VALUES["LANES"][-1] if packets else 1, "AOVS": int(bool(sample_aovs))}


def packets_cover(scene, features):
    """Whether the packet integrator (kernels/path_packets.h) renders `scene`: none of the other
    features, every material some shape uses diffuse (emissive included), dielectric reflecting
    untinted, conductor (rough ones without energy compensation) or plastic, its colour and its
    opacity (a mask) alone from textures (no other textured parameter, bump or normal map or back
    material), emitting triangles and spheres, point, spot and directional lights and the
    environment, and emitters visible to the camera; path tracing, or the direct integrator where
    no surface is a mask (its camera rays cross masks as the path tracer's do not)."""
    if any(features[name] != value for name, value in PACKET_FEATURES.items()):
        return False
    if scene.render.hide_emitters:
        return False
    for shape in scene.shapes:
        material = scene.materials[shape.material]
        if material.type not in ("diffuse", "emissive", "dielectric", "conductor", "plastic"):
            return False
        if scene.render.integrator == "direct" and lets_light_through(material):
            return False
        if set(material.textures) - {"color", "opacity"} or detail_beyond_textures(material, masks=False):
            return False
        if material.type in ("dielectric", "conductor") and not _is_smooth(material) and material.energy_compensation:
            return False
        if material.type == "dielectric" and not np.all(material.reflection_tint == 1):
            return False
    return all(light.type in PACKET_LIGHTS for light in scene.lights)


def _is_smooth(material):
    """A delta lobe, as material_is_delta in kernels/materials/bsdf.h decides it (float32 alpha
    against MICROFACET_MIN_ALPHA)."""
    roughness = np.float32(material.roughness)
    return bool(roughness * roughness < np.float32(1e-3))


def _is_specular(material):
    """An index-matched dielectric is not: it is rendered as an interface (scene.Material)."""
    return material.type in SPECULAR_MATERIALS and not material.index_matched


def _uses_media(scene):
    """Media matter when some region holds one, or some surface is a pure medium boundary (an
    interface, or an index-matched dielectric, rendered as one)."""
    return scene.medium >= 0 or any(s.interior >= 0 or s.exterior >= 0 for s in scene.shapes) or any(
        m.type == "interface" or m.index_matched for m in scene.materials)


def all_feature_combinations():
    """Every combination of feature values the defines allow (for compile checks). Grid media
    are media: GRID_MEDIA > 0 comes with MEDIA = 1 only; packets (LANES 8) come with none of
    PACKET_FEATURES."""
    names = list(FEATURE_VALUES)
    for values in itertools.product(*(FEATURE_VALUES[n] for n in names)):
        features = dict(zip(names, values))
        if features["GRID_MEDIA"] and not features["MEDIA"]:
            continue
        if features["LANES"] > 1 and any(features[n] != v for n, v in PACKET_FEATURES.items()):
            continue
        yield features


def describe(features):
    """Human-readable list of enabled features."""
    env_names = {v: k for k, v in ENVIRONMENT_MODES.items()}
    method_names = {v: k for k, v in VOLUME_METHODS.items()}
    parts = [f"environment={env_names[features['ENVIRONMENT']]}"]
    parts += [name.lower() for name, value in features.items()
              if name not in ("ENVIRONMENT", "GRID_MEDIA", "LANES") and value]
    if features.get("GRID_MEDIA"):
        parts.append(f"grid_media={method_names[features['GRID_MEDIA']]}")
    if features.get("LANES", 1) > 1:
        parts.append(f"packets of {features['LANES']}")
    return ", ".join(parts)


def entry_file(features):
    """The kernel source that features compile: the megakernel, or its packet form."""
    return "integrator_packets.cl" if features.get("LANES", 1) > 1 else "integrator.cl"
