"""BSDFs: the scene's materials (without emission: shape.py adds an area emitter's).

| plugin | parameter (Mitsuba's default) | clrender material |
|---|---|---|
| `diffuse` | `reflectance` (0.5) | `diffuse`, one-sided (black seen from behind, as Mitsuba's) |
| `twosided` | one nested `diffuse`, `conductor` or `roughconductor` | the same, `two_sided` |
| `dielectric` | `int_ior` (bk7), `ext_ior` (air): numbers or IOR_PRESETS names; `specular_transmittance` (1) | `dielectric` (`ior`, `exterior_ior`, `tint`); `specular_reflectance` other than 1 is an error |
| `roughdielectric` | the same, `distribution` (must be ggx), `alpha` (0.1) or equal `alpha_u`/`alpha_v` | rough `dielectric`, `roughness` sqrt(alpha), single scattering |
| `conductor` | `specular_reflectance` (1), `material` (none: a perfect mirror; CONDUCTOR_PRESETS) or `eta`/`k` | `conductor`, `tint` = specular_reflectance x reflectance at normal incidence (a warning for presets and eta/k) |
| `roughconductor` | the same, `distribution` (ggx), `alpha` | rough `conductor`, single scattering |
| `principled` | `base_color` (0.5), `roughness` (0.5), `anisotropic`, `metallic`, `spec_trans`, `spec_tint`, `sheen`, `sheen_tint`, `clearcoat`, `clearcoat_gloss`, `flatness` (0): numbers or textures; `eta` or `specular` (0.5), the three `*_sampling_rate` (1): numbers | `principled`, the same names |
| `null` | | `interface` |
| accepted | `sample_visible` (rough lobes) | |
"""
import numpy as np

from ..principled import SAMPLING_RATES, WEIGHTS
from .texture import color_or_texture, is_textured, number_or_texture
from .values import fmt, parse_float

BSDFS = ("diffuse", "dielectric", "roughdielectric", "conductor", "roughconductor", "principled", "twosided", "null")

# Mitsuba's named indices of refraction.
IOR_PRESETS = {
    "vacuum": 1.0, "helium": 1.000036, "hydrogen": 1.000132, "air": 1.000277,
    "carbon dioxide": 1.00045, "water": 1.3330, "acetone": 1.36, "ethanol": 1.361,
    "carbon tetrachloride": 1.461, "glycerol": 1.4729, "benzene": 1.501, "silicone oil": 1.52045,
    "bromine": 1.661, "water ice": 1.31, "fused quartz": 1.458, "pyrex": 1.470,
    "acrylic glass": 1.49, "polypropylene": 1.49, "bk7": 1.5046, "sodium chloride": 1.544,
    "amber": 1.55, "pet": 1.575, "diamond": 2.419,
}

# Normal-incidence reflectance (linear RGB) of Mitsuba 3.9's conductor presets, from
# `conductor` in scalar_rgb: the weight of a sample at normal incidence (tests check it).
# AlSb is left out: Mitsuba's own RGB value is NaN.
CONDUCTOR_PRESETS = {
    "Ag": (0.9748, 0.9575, 0.9063), "Al": (0.928, 0.9178, 0.9189), "AlAs": (0.32, 0.2783, 0.143),
    "Au": (0.9667, 0.802, 0.3241), "Be": (0.5975, 0.5206, 0.5062), "Cr": (0.6876, 0.6491, 0.687),
    "CsI": (0.1325, 0.0675, 0.0619), "Cu": (0.952, 0.6198, 0.5106), "Cu2O": (0.3147, 0.2455, 0.2379),
    "CuO": (0.2907, 0.1982, 0.1834), "Cu_palik": (0.9494, 0.6217, 0.5092), "Hg": (0.814, 0.7702, 0.7631),
    "HgTe": (0.4699, 0.3665, 0.3507), "Ir": (0.7426, 0.6802, 0.6308), "K": (0.9539, 0.9363, 0.9201),
    "Li": (0.9248, 0.8844, 0.7933), "MgO": (0.1244, 0.0603, 0.0526), "Mo": (0.6182, 0.5618, 0.5409),
    "Na_palik": (0.9785, 0.9597, 0.9315), "Nb": (0.564, 0.4895, 0.4731), "Ni_palik": (0.7001, 0.5942, 0.4936),
    "Rh": (0.8243, 0.7544, 0.7216), "Se": (0.3793, 0.2507, 0.2413), "Se-e": (0.5019, 0.4029, 0.4225),
    "SiC": (0.2711, 0.1873, 0.1808), "SnTe": (0.407, 0.1084, 0.0152), "Ta": (0.4565, 0.3419, 0.3799),
    "Te": (0.635, 0.5781, 0.5617), "Te-e": (0.71, 0.6728, 0.6532), "ThF4": (0.0861, 0.0328, 0.0264),
    "TiC": (0.5482, 0.4397, 0.4116), "TiN": (0.6409, 0.4523, 0.1976), "TiO2": (0.3039, 0.2246, 0.238),
    "TiO2-e": (0.2631, 0.1855, 0.1951), "VC": (0.5297, 0.4179, 0.3798), "VN": (0.5251, 0.3926, 0.3106),
    "V_palik": (0.5727, 0.5107, 0.5365), "W": (0.5746, 0.4778, 0.4331), "a-C": (0.2794, 0.194, 0.1691),
    "d-C": (0.2123, 0.1579, 0.1449),
}
# The *_palik variants that equal their base preset.
CONDUCTOR_PRESETS.update({f"{name}_palik": CONDUCTOR_PRESETS[name] for name in (
    "AlAs", "Be", "CsI", "Cu2O", "CuO", "HgTe", "Ir", "K", "Li", "MgO", "Mo", "Nb", "Rh", "Se",
    "Se-e", "SiC", "SnTe", "Ta", "Te", "Te-e", "ThF4", "TiC", "TiN", "TiO2", "TiO2-e", "VC", "VN",
    "d-C")})
CONDUCTOR_PRESETS.update({"Hg_palik": CONDUCTOR_PRESETS["Hg"]})


def read_bsdf(plugin, reader, two_sided=False):
    """A material dict (without its name) for one BSDF element."""
    kind = plugin.type
    if kind == "twosided":
        inner = plugin.nested("bsdf")
        if len(inner) != 1:
            raise plugin.error("twosided with different front and back BSDFs is not supported "
                               "(give one nested BSDF)")
        plugin.finish()
        if inner[0].type not in ("diffuse", "conductor", "roughconductor"):
            raise inner[0].error(f"twosided around '{inner[0].type}' is not supported "
                                 "(only diffuse, conductor, roughconductor; Mitsuba rejects transmission)")
        return read_bsdf(inner[0], reader, two_sided=True)
    if kind == "diffuse":
        material = {"type": "diffuse", "albedo": color_or_texture(plugin, "reflectance", 0.5, reader),
                    "two_sided": two_sided}
    elif kind in ("dielectric", "roughdielectric"):
        material = {"type": "dielectric", "ior": _ior(plugin, "int_ior", "bk7"),
                    "exterior_ior": _ior(plugin, "ext_ior", "air")}
        if np.any(plugin.color("specular_reflectance", 1.0, reader.out.warnings) != 1.0):
            raise plugin.error("specular_reflectance other than 1 is not supported on dielectrics")
        material["tint"] = color_or_texture(plugin, "specular_transmittance", 1.0, reader)
        if kind == "roughdielectric":
            material.update(_roughness(plugin, reader))
    elif kind in ("conductor", "roughconductor"):
        reflectance = color_or_texture(plugin, "specular_reflectance", 1.0, reader)
        f0 = _conductor_reflectance(plugin, reader)
        if is_textured(reflectance) and np.any(f0 != 1):
            raise plugin.error("a textured specular_reflectance with a conductor material or eta/k is not "
                               "supported (only on a perfect mirror, material 'none')")
        material = {"type": "conductor", "two_sided": two_sided,
                    "tint": reflectance if is_textured(reflectance) else (np.asarray(reflectance) * f0).tolist()}
        if kind == "roughconductor":
            material.update(_roughness(plugin, reader))
    elif kind == "principled":
        material = _principled(plugin, reader)
    elif kind == "null":
        material = {"type": "interface"}
    else:
        raise plugin.error(f"unsupported BSDF '{kind}' (supported: {', '.join(BSDFS)})")
    plugin.finish()
    return material


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


def _roughness(plugin, reader):
    """GGX alpha -> the format's roughness (alpha = roughness^2), or a texture of alpha; single
    scattering, as Mitsuba."""
    distribution = plugin.string("distribution", "beckmann")
    if distribution != "ggx":
        raise plugin.error(f"microfacet distribution '{distribution}' is not supported: clrender's "
                           "rough lobes are GGX (add <string name=\"distribution\" value=\"ggx\"/>; "
                           "Mitsuba's default is beckmann)")
    if plugin.has("alpha") and (plugin.has("alpha_u") or plugin.has("alpha_v")):
        raise plugin.error("give either alpha or alpha_u and alpha_v")
    alpha = number_or_texture(plugin, "alpha", 0.1, reader)
    if is_textured(alpha):
        plugin.accept("sample_visible")
        return {"alpha": alpha, "energy_compensation": False}
    if plugin.has("alpha_u") or plugin.has("alpha_v"):
        alpha_u, alpha_v = plugin.number("alpha_u", 0.1), plugin.number("alpha_v", 0.1)
        if alpha_u != alpha_v:
            raise plugin.error("anisotropic roughness (alpha_u != alpha_v) is not supported")
        alpha = alpha_u
    if not 0 <= alpha <= 1:
        raise plugin.error(f"alpha must be in [0, 1], got {alpha:g}")
    plugin.accept("sample_visible")   # a sampling choice: the same image
    return {"roughness": float(np.sqrt(alpha)), "energy_compensation": False}


def _conductor_reflectance(plugin, reader):
    """Reflectance at normal incidence of the conductor's material or eta/k (1 for 'none')."""
    if plugin.has("material") and (plugin.has("eta") or plugin.has("k")):
        raise plugin.error("give either material or eta and k")
    if plugin.has("eta") or plugin.has("k"):
        eta = plugin.color("eta", 0.0, reader.out.warnings)
        k = plugin.color("k", 1.0, reader.out.warnings)
        f0 = ((eta - 1) ** 2 + k ** 2) / ((eta + 1) ** 2 + k ** 2)
        reader.warn(f"{plugin.element.where()}: eta/k approximated by the normal-incidence "
                    f"reflectance {fmt(f0)} at every angle")
        return f0
    name = plugin.string("material", "none")
    if name == "none":
        return np.ones(3)
    if name not in CONDUCTOR_PRESETS:
        raise plugin.error(f"unknown conductor material '{name}' (known: none, {', '.join(sorted(CONDUCTOR_PRESETS))})")
    f0 = np.array(CONDUCTOR_PRESETS[name])
    reader.warn(f"{plugin.element.where()}: material '{name}' approximated by its normal-incidence "
                f"reflectance {fmt(f0)} at every angle (no Fresnel darkening or colour shift)")
    return f0
