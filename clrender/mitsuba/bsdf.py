"""BSDFs: the scene's materials (without emission: shape.py adds an area emitter's).

| plugin | parameter (Mitsuba's default) | clrender material |
|---|---|---|
| `diffuse` | `reflectance` (0.5) | `diffuse`, one-sided (black seen from behind, as Mitsuba's) |
| `twosided` | one nested `diffuse`, `conductor`, `roughconductor`, `plastic` or `roughplastic` | the same, `two_sided` |
| `dielectric` | `int_ior` (bk7), `ext_ior` (air): numbers or IOR_PRESETS names; `specular_reflectance` (1), `specular_transmittance` (1) | `dielectric` (`ior`, `exterior_ior`, `reflection_tint`, `tint`) |
| `roughdielectric` | the same, `distribution` (beckmann; or ggx), `alpha` (0.1) or equal `alpha_u`/`alpha_v` | rough `dielectric`, `roughness` sqrt(alpha), `masking` separable, single scattering |
| `thindielectric` | `int_ior`, `ext_ior`, `specular_reflectance`, `specular_transmittance` as `dielectric` | `thin_dielectric` |
| `conductor` | `specular_reflectance` (1), `material` (none: a perfect mirror; CONDUCTOR_PRESETS) or `eta`/`k` (0, 1) | `conductor` (`tint`, `material` or `eta` and `k`) |
| `roughconductor` | the same, `distribution` (beckmann), `alpha` | rough `conductor`, `masking` separable, single scattering |
| `plastic` | `int_ior` (polypropylene), `ext_ior` (air), `diffuse_reflectance` (0.5), `specular_reflectance` (1), `nonlinear` (false) | `plastic` (`ior`, `exterior_ior`, `diffuse`, `specular`, `nonlinear`), one-sided |
| `roughplastic` | the same, `distribution` (beckmann; or ggx), `alpha` (0.1; a number: Mitsuba takes no texture) or equal `alpha_u`/`alpha_v` | rough `plastic`, `roughness` sqrt(alpha) |
| `null` | | `interface` |
| accepted | `sample_visible` (rough lobes) | |
"""
import numpy as np

from ..conductor_presets import CONDUCTOR_PRESETS
from ..layout import MICROFACET_DISTRIBUTIONS
from .texture import _is_texture, color_or_texture, is_textured, number_or_texture
from .values import parse_float

BSDFS = ("diffuse", "dielectric", "roughdielectric", "thindielectric", "conductor", "roughconductor", "plastic",
         "roughplastic", "twosided", "null")
TWO_SIDED = ("diffuse", "conductor", "roughconductor", "plastic", "roughplastic")

# Mitsuba's named indices of refraction.
IOR_PRESETS = {
    "vacuum": 1.0, "helium": 1.000036, "hydrogen": 1.000132, "air": 1.000277,
    "carbon dioxide": 1.00045, "water": 1.3330, "acetone": 1.36, "ethanol": 1.361,
    "carbon tetrachloride": 1.461, "glycerol": 1.4729, "benzene": 1.501, "silicone oil": 1.52045,
    "bromine": 1.661, "water ice": 1.31, "fused quartz": 1.458, "pyrex": 1.470,
    "acrylic glass": 1.49, "polypropylene": 1.49, "bk7": 1.5046, "sodium chloride": 1.544,
    "amber": 1.55, "pet": 1.575, "diamond": 2.419,
}

def read_bsdf(plugin, reader, two_sided=False):
    """A material dict (without its name) for one BSDF element."""
    kind = plugin.type
    if kind == "twosided":
        inner = plugin.nested("bsdf")
        if len(inner) != 1:
            raise plugin.error("twosided with different front and back BSDFs is not supported "
                               "(give one nested BSDF)")
        plugin.finish()
        if inner[0].type not in TWO_SIDED:
            raise inner[0].error(f"twosided around '{inner[0].type}' is not supported "
                                 f"(only {', '.join(TWO_SIDED)}; Mitsuba rejects transmission)")
        return read_bsdf(inner[0], reader, two_sided=True)
    if kind == "diffuse":
        material = {"type": "diffuse", "albedo": color_or_texture(plugin, "reflectance", 0.5, reader),
                    "two_sided": two_sided}
    elif kind in ("dielectric", "roughdielectric", "thindielectric"):
        material = {"type": "thin_dielectric" if kind == "thindielectric" else "dielectric",
                    "ior": _ior(plugin, "int_ior", "bk7"), "exterior_ior": _ior(plugin, "ext_ior", "air"),
                    "reflection_tint": color_or_texture(plugin, "specular_reflectance", 1.0, reader),
                    "tint": color_or_texture(plugin, "specular_transmittance", 1.0, reader)}
        if kind == "roughdielectric":
            material.update(_roughness(plugin, reader))
    elif kind in ("conductor", "roughconductor"):
        material = {"type": "conductor", "two_sided": two_sided,
                    "tint": color_or_texture(plugin, "specular_reflectance", 1.0, reader),
                    **_complex_ior(plugin, reader)}
        if kind == "roughconductor":
            material.update(_roughness(plugin, reader))
    elif kind in ("plastic", "roughplastic"):
        material = _plastic(plugin, reader, two_sided)
    elif kind == "null":
        material = {"type": "interface"}
    else:
        raise plugin.error(f"unsupported BSDF '{kind}' (supported: {', '.join(BSDFS)})")
    plugin.finish()
    return material


def _ior(plugin, name, default):
    element = plugin.take(name, ("float", "integer", "string"))
    if element is None:
        return IOR_PRESETS[default]
    if element.tag == "string":
        value = element.attrs.get("value", "").lower()
        if value not in IOR_PRESETS:
            raise element.error(f"unknown index of refraction '{value}' (known: {', '.join(IOR_PRESETS)})")
        return IOR_PRESETS[value]
    return parse_float(element)


def _plastic(plugin, reader, two_sided):
    material = {"type": "plastic", "two_sided": two_sided, "ior": _ior(plugin, "int_ior", "polypropylene"),
                "exterior_ior": _ior(plugin, "ext_ior", "air"),
                "diffuse": color_or_texture(plugin, "diffuse_reflectance", 0.5, reader),
                "specular": color_or_texture(plugin, "specular_reflectance", 1.0, reader),
                "nonlinear": plugin.boolean("nonlinear", False)}
    if material["ior"] == material["exterior_ior"]:
        raise plugin.error("int_ior and ext_ior must differ (as Mitsuba requires)")
    if plugin.type == "roughplastic":
        if _is_texture(plugin, "alpha"):
            raise plugin.error("a textured alpha is not supported on roughplastic (Mitsuba takes a number)")
        # Its masking is Mitsuba's always, and its tables are its model (no energy compensation).
        model = _roughness(plugin, reader)
        material.update((k, v) for k, v in model.items() if k not in ("masking", "energy_compensation"))
    return material


def _roughness(plugin, reader):
    """Mitsuba's microfacet model: the distribution (beckmann by default, or ggx), alpha as the
    format's roughness (alpha = roughness^2) or a texture of alpha, separable masking-shadowing,
    single scattering, as Mitsuba's rough BSDFs."""
    distribution = plugin.string("distribution", "beckmann").lower()
    if distribution not in MICROFACET_DISTRIBUTIONS:
        raise plugin.error(f"unknown microfacet distribution '{distribution}' (known: "
                           f"{', '.join(MICROFACET_DISTRIBUTIONS)})")
    model = {"distribution": distribution, "masking": "separable", "energy_compensation": False}
    if plugin.has("alpha") and (plugin.has("alpha_u") or plugin.has("alpha_v")):
        raise plugin.error("give either alpha or alpha_u and alpha_v")
    plugin.accept("sample_visible")   # a sampling choice: the same image in expectation
    alpha = number_or_texture(plugin, "alpha", 0.1, reader)
    if is_textured(alpha):
        return {"alpha": alpha, **model}
    if plugin.has("alpha_u") or plugin.has("alpha_v"):
        alpha_u, alpha_v = plugin.number("alpha_u", 0.1), plugin.number("alpha_v", 0.1)
        if alpha_u != alpha_v:
            raise plugin.error("anisotropic roughness (alpha_u != alpha_v) is not supported")
        alpha = alpha_u
    if not 0 <= alpha <= 1:
        raise plugin.error(f"alpha must be in [0, 1], got {alpha:g}")
    return {"roughness": float(np.sqrt(alpha)), **model}


def _complex_ior(plugin, reader):
    """A conductor's `material` (a preset name) or `eta` and `k` (Mitsuba's defaults 0 and 1), as
    the JSON fields; nothing for Mitsuba's default, material 'none' (a perfect mirror)."""
    if plugin.has("material") and (plugin.has("eta") or plugin.has("k")):
        raise plugin.error("give either material or eta and k")
    if plugin.has("eta") or plugin.has("k"):
        return {"eta": _unbounded_color(plugin, "eta", 0.0, reader).tolist(),
                "k": _unbounded_color(plugin, "k", 1.0, reader).tolist()}
    name = plugin.string("material", "none")
    if name == "none":
        return {}
    if name not in CONDUCTOR_PRESETS:
        raise plugin.error(f"unknown conductor material '{name}' (known: none, {', '.join(sorted(CONDUCTOR_PRESETS))})")
    return {"material": name}


def _unbounded_color(plugin, name, default, reader):
    """An unbounded RGB value (eta, k): <rgb>, <float> and uniform spectra as given; a sampled
    spectrum without D65 and unclamped above, as Mitsuba's unbounded textures convert it (the
    conversion of an emitter's; a uniform one on an emitter would be an equal-energy
    illuminant)."""
    sampled = plugin.has(name) and ":" in plugin.properties[name][0].attrs.get("value", "")
    return plugin.color(name, default, reader.out.warnings, emitter=sampled)
