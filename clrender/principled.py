"""The `principled` material: Mitsuba 3.9's principled BSDF (kernels/materials/principled.h).

Its parameters carry Mitsuba's names, defaults and meaning (docs/scene-format.md); base_color is
the Material's albedo (the record's colour). Every weight and the roughness may be a texture.
"""
from dataclasses import dataclass

import numpy as np

from . import layout
from .errors import SceneError

# Texturable weights in [0, 1] (layout.PRINCIPLED_WEIGHTS), all 0 by default.
WEIGHTS = layout.PRINCIPLED_WEIGHTS
SAMPLING_RATES = ("main_specular_sampling_rate", "clearcoat_sampling_rate", "diffuse_reflectance_sampling_rate")
# specular = 12.5 would make eta infinite (eta_from_specular).
SPECULAR_LIMIT = 12.5


@dataclass
class Principled:
    roughness: float = 0.5
    anisotropic: float = 0.0
    metallic: float = 0.0
    spec_trans: float = 0.0
    spec_tint: float = 0.0
    sheen: float = 0.0
    sheen_tint: float = 0.0
    clearcoat: float = 0.0
    clearcoat_gloss: float = 0.0
    flatness: float = 0.0
    eta: float = 1.5          # interior / exterior index of refraction
    main_specular_sampling_rate: float = 1.0
    clearcoat_sampling_rate: float = 1.0
    diffuse_reflectance_sampling_rate: float = 1.0


def eta_from_specular(specular):
    """Mitsuba's map from `specular` (the normal-incidence reflectance / 0.08) to eta."""
    return 2.0 / (1.0 - np.sqrt(0.08 * specular)) - 1.0


def read_principled(node, texturable):
    """The parameters of a principled material (a scene._Node and its scene._TexturableReader;
    textured parameters are recorded in the reader's maps and keep their default here)."""
    p = Principled()
    p.roughness = float(texturable.number("roughness", "principled_roughness", p.roughness, low=0, high=1))
    for name in WEIGHTS:
        setattr(p, name, float(texturable.number(name, f"principled_{name}", 0.0, low=0, high=1)))
    for name in SAMPLING_RATES:
        setattr(p, name, float(node.number(name, 1.0, low=0, low_open=True)))
    if "eta" in node.data and "specular" in node.data:
        raise SceneError(node.where, "give either eta or specular")
    if "specular" in node.data:
        specular = node.number("specular", low=0)
        if not specular < SPECULAR_LIMIT:
            raise SceneError(node.at("specular"), f"must be < {SPECULAR_LIMIT} (eta = 2 / (1 - sqrt(0.08 "
                                                  f"specular)) - 1 must be finite), got {specular}")
        p.eta = float(eta_from_specular(specular))
    else:
        p.eta = float(node.number("eta", p.eta, low=0, low_open=True))
    transmits = p.spec_trans > 0 or "principled_spec_trans" in texturable.maps
    if transmits and np.float32(p.eta) == 1:
        raise SceneError(node.at("eta" if "eta" in node.data else "specular"),
                         "an index of 1 with spec_trans leaves transmission no half vector: its samples "
                         "would all go straight through, where the lobe has no density")
    return p


def needs_tangents(material):
    """Whether the material's lobes depend on the tangent direction (anisotropic, constant or
    textured): then hits need dp/du, which comes with uv (the TEXTURES feature)."""
    p = material.principled
    return p is not None and (p.anisotropic != 0 or "principled_anisotropic" in material.textures)


def write_fields(record, p):
    """The principled fields of a Material record (scalars as float32, as the kernel reads them)."""
    put = lambda name, value: layout.set_field(record, layout.MATERIAL_FIELDS, name, value)  # noqa: E731
    put("principled_roughness", p.roughness)
    for name in WEIGHTS:
        put(f"principled_{name}", getattr(p, name))
    put("principled_eta", p.eta)
    put("principled_specular_rate", p.main_specular_sampling_rate)
    put("principled_clearcoat_rate", p.clearcoat_sampling_rate)
    put("principled_diffuse_rate", p.diffuse_reflectance_sampling_rate)
