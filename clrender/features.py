"""The one place that decides which kernel features a scene needs.

The megakernel is compiled with one -D define per feature, so code a scene does not use is not
compiled. Features are deliberately coarse: each new combination costs a kernel build.
"""
import itertools

from .layout import ENVIRONMENT_MODES

# Every feature and the values it may take; the first value is "absent".
FEATURE_VALUES = {
    "ENVIRONMENT": tuple(ENVIRONMENT_MODES.values()),
    "DELTA_LIGHTS": (0, 1),
    "MEDIA": (0, 1),
    "TOON": (0, 1),
    # Specular materials: smooth and rough dielectrics and conductors (one feature for both:
    # they share the microfacet code, and every feature doubles the combinations to build).
    "DIELECTRIC": (0, 1),
}

SPECULAR_MATERIALS = ("dielectric", "conductor")


def scene_features(scene):
    """The feature values (name -> int) that `scene` needs."""
    environment = scene.environment
    if environment is None:
        env_mode = ENVIRONMENT_MODES["none"]
    else:
        env_mode = ENVIRONMENT_MODES["image" if environment.image is not None else "constant"]
    return {
        "ENVIRONMENT": env_mode,
        "DELTA_LIGHTS": int(any(light.type in ("point", "directional") for light in scene.lights)),
        "MEDIA": int(_uses_media(scene)),
        # Only materials some shape uses: an unused toon material cannot be hit.
        "TOON": int(any(scene.materials[shape.material].type == "toon" for shape in scene.shapes)),
        # Only materials that some shape uses: an unused glass definition costs no kernel code.
        "DIELECTRIC": int(any(scene.materials[shape.material].type in SPECULAR_MATERIALS
                              for shape in scene.shapes)),
    }


def _uses_media(scene):
    """Media matter when some region holds one, or some surface is a pure medium boundary."""
    return scene.medium >= 0 or any(s.interior >= 0 or s.exterior >= 0 for s in scene.shapes) or any(
        m.type == "interface" for m in scene.materials)


def all_feature_combinations():
    """Every combination of feature values the defines allow (for compile checks)."""
    names = list(FEATURE_VALUES)
    for values in itertools.product(*(FEATURE_VALUES[n] for n in names)):
        yield dict(zip(names, values))


def describe(features):
    """Human-readable list of enabled features."""
    env_names = {v: k for k, v in ENVIRONMENT_MODES.items()}
    parts = [f"environment={env_names[features['ENVIRONMENT']]}"]
    parts += [name.lower() for name, value in features.items() if name != "ENVIRONMENT" and value]
    return ", ".join(parts)
