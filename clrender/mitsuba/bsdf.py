"""BSDFs: the scene's materials (without emission: shape.py adds an area emitter's).

| plugin | parameter (Mitsuba's default) | clrender material |
|---|---|---|
| `diffuse` | `reflectance` (0.5) | `diffuse`, one-sided (black seen from behind, as Mitsuba's) |
| `twosided` | one nested BSDF that does not transmit, or two (front, back) | the same, `two_sided`; the second one its `back` |
| `mask` | `opacity` (0.5: a number, a texture, or RGB: their mean, as Mitsuba's eval_1), one nested BSDF | the nested one with `opacity` |
| `bumpmap` | one nested texture (any name; not a checkerboard: Mitsuba has no gradient of one), `scale` (1), one nested BSDF | the nested one with `bump` |
| `normalmap` | `normalmap` (a texture), one nested BSDF | the nested one with `normal_map` |
| accepted | `use_shadowing_function`, `flip_invalid_normals` (bumpmap, normalmap) when true, their default | |
| `dielectric` | `int_ior` (bk7), `ext_ior` (air): numbers or IOR_PRESETS names; `specular_reflectance` (1), `specular_transmittance` (1) | `dielectric` (`ior`, `exterior_ior`, `reflection_tint`, `tint`) |
| `roughdielectric` | the same, `distribution` (beckmann; or ggx), `alpha` (0.1) or equal `alpha_u`/`alpha_v` | rough `dielectric`, `roughness` sqrt(alpha), `masking` separable, single scattering |
| `thindielectric` | `int_ior`, `ext_ior`, `specular_reflectance`, `specular_transmittance` as `dielectric` | `thin_dielectric` |
| `conductor` | `specular_reflectance` (1), `material` (none: a perfect mirror; CONDUCTOR_PRESETS) or `eta`/`k` (0, 1) | `conductor` (`tint`, `material` or `eta` and `k`) |
| `roughconductor` | the same, `distribution` (beckmann), `alpha` | rough `conductor`, `masking` separable, single scattering |
| `plastic` | `int_ior` (polypropylene), `ext_ior` (air), `diffuse_reflectance` (0.5), `specular_reflectance` (1), `nonlinear` (false) | `plastic` (`ior`, `exterior_ior`, `diffuse`, `specular`, `nonlinear`), one-sided |
| `roughplastic` | the same, `distribution` (beckmann; or ggx), `alpha` (0.1; a number: Mitsuba takes no texture) or equal `alpha_u`/`alpha_v` | rough `plastic`, `roughness` sqrt(alpha) |
| `principled` | `base_color` (0.5), `roughness` (0.5), `anisotropic`, `metallic`, `spec_trans`, `spec_tint`, `sheen`, `sheen_tint`, `clearcoat`, `clearcoat_gloss`, `flatness` (0): numbers or textures; `eta` or `specular` (0.5), the three `*_sampling_rate` (1): numbers | `principled`, the same names |
| `null` | | `interface` |
| accepted | `sample_visible` (rough lobes) | |

Wrappers are flattened onto the material they wrap, whatever their order (`mask` around
`twosided` around `bumpmap` ...): each sets its field on it, and on its back material when it
wraps a `twosided` with two BSDFs (read_bsdf returns the back's dict under `back`; shape.py
makes it a material of its own). An unsupported BSDF inside a wrapper is reported as itself.
"""
import numpy as np

from ..conductor_presets import CONDUCTOR_PRESETS
from ..layout import MICROFACET_DISTRIBUTIONS
from .texture import _is_texture, color_or_texture, is_textured, number_or_texture, read_texture
from ..principled import SAMPLING_RATES, WEIGHTS
from .values import parse_float

BSDFS = ("diffuse", "dielectric", "roughdielectric", "thindielectric", "conductor", "roughconductor", "plastic",
         "roughplastic", "twosided", "null", "mask", "bumpmap", "normalmap",
         "principled")

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
    """A material dict (without its name) for one BSDF element; `two_sided`: inside a twosided."""
    kind = plugin.type
    if kind in WRAPPERS:
        return WRAPPERS[kind](plugin, reader, two_sided)
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
    elif kind == "principled":
        material = _principled(plugin, reader)
    elif kind == "null":
        material = {"type": "interface"}
    else:
        raise plugin.error(f"unsupported BSDF '{kind}' (supported: {', '.join(BSDFS)})")
    plugin.finish()
    return material


def _nested_bsdfs(plugin, counts):
    """The nested BSDF elements of a wrapper (their number in `counts`), its properties done."""
    nested = plugin.nested("bsdf")
    plugin.finish()
    if len(nested) not in counts:
        raise plugin.error(f"{plugin.type} needs {' or '.join(map(str, counts))} nested BSDF"
                           + ("s" if max(counts) > 1 else "") + f", got {len(nested)}")
    return nested


def _read_wrapped(plugin, reader, two_sided, key, value):
    """The nested BSDF's material with `key` set, on its back material too (a wrapper wraps both
    sides); one of each kind of wrapper (a mask; a bump or a normal map) per material."""
    material = read_bsdf(_nested_bsdfs(plugin, (1,))[0], reader, two_sided)
    sides = [material] + ([material["back"]] if "back" in material else [])
    kinds = ("opacity",) if key == "opacity" else ("bump", "normal_map")
    if any(k in side for side in sides for k in kinds):
        raise plugin.error(f"a {plugin.type} around a BSDF that already has "
                           f"{'a mask' if key == 'opacity' else 'a bump or normal map'} is not supported")
    for side in sides:
        side[key] = value
    return material


def _twosided(plugin, reader, two_sided):
    """Mitsuba's twosided: the BSDF on both sides, or a front and a back BSDF; neither may
    transmit (Mitsuba rejects them)."""
    nested = _nested_bsdfs(plugin, (1, 2))
    sides = [read_bsdf(element, reader, two_sided=True) for element in nested]
    for element, side in zip(nested, sides):
        if side["type"] == "principled":
            raise element.error("a 'principled' inside twosided is not supported")
        if side["type"] in ("dielectric", "thin_dielectric", "interface") or "opacity" in side:
            raise element.error(f"a '{element.type}' inside twosided is not supported: it transmits light "
                                "(Mitsuba's twosided rejects it)")
    if len(sides) == 2:
        if "back" in sides[0] or "back" in sides[1]:
            raise plugin.error("a twosided with two BSDFs around another one is not supported")
        sides[0]["back"] = sides[1]
    return sides[0]


def _mask(plugin, reader, two_sided):
    """Mitsuba's mask: opacity clamped to [0, 1] (as Mitsuba's eval_opacity)."""
    opacity = _opacity(plugin, reader)
    if not is_textured(opacity):
        opacity = float(np.clip(opacity, 0.0, 1.0))
    return _read_wrapped(plugin, reader, two_sided, "opacity", opacity)


def _opacity(plugin, reader):
    """A number or a texture; a constant colour is its mean (Mitsuba's eval_1 of one)."""
    if plugin.has("opacity") and plugin.properties["opacity"][0].tag in ("rgb", "spectrum"):
        return float(plugin.color("opacity", 0.5, reader.out.warnings).mean())
    return number_or_texture(plugin, "opacity", 0.5, reader)


def _bumpmap(plugin, reader, two_sided):
    textures = plugin.nested("texture")
    if len(textures) != 1:
        raise plugin.error(f"bumpmap needs one nested texture, got {len(textures)}")
    if textures[0].type == "checkerboard":
        raise textures[0].error("a checkerboard has no gradient in Mitsuba (eval_1_grad): a bumpmap needs a bitmap")
    bump = {"texture": read_texture(textures[0], reader), "scale": plugin.number("scale", 1.0)}
    _accept_true(plugin, "use_shadowing_function", "flip_invalid_normals")
    return _read_wrapped(plugin, reader, two_sided, "bump", bump)


def _normalmap(plugin, reader, two_sided):
    texture = plugin.object("normalmap", "texture")
    if texture is None:
        raise plugin.error("normalmap needs a texture named 'normalmap'")
    _accept_true(plugin, "use_shadowing_function", "flip_invalid_normals")
    return _read_wrapped(plugin, reader, two_sided, "normal_map", {"texture": read_texture(texture, reader)})


def _accept_true(plugin, *names):
    """Options whose default (true) is what clrender does; false is not supported."""
    for name in names:
        if plugin.has(name) and not plugin.boolean(name):
            raise plugin.error(f"{name} false is not supported (clrender does what true does)")


WRAPPERS = {"twosided": _twosided, "mask": _mask, "bumpmap": _bumpmap, "normalmap": _normalmap}


def _principled(plugin, reader):
    """Mitsuba's parameters, under the same names; those absent keep Mitsuba's defaults, which
    are the format's (clrender/principled.py checks the values)."""
    if plugin.has("eta") and plugin.has("specular"):
        raise plugin.error("give either eta or specular (Mitsuba refuses both)")
    material = {"type": "principled", "base_color": color_or_texture(plugin, "base_color", 0.5, reader)}
    for name in ("roughness", *WEIGHTS):
        if plugin.has(name):
            material[name] = number_or_texture(plugin, name, None, reader)
    for name in ("eta", "specular", *SAMPLING_RATES):
        if plugin.has(name):
            material[name] = plugin.number(name)
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
