"""Conductors with a complex index of refraction (kernels/materials/conductor.h): the Fresnel
reflectance against the textbook amplitudes, the tint-only mirror, presets and JSON fields,
reciprocity of the rough lobes. Sampling of rough conductors: tests/test_dielectric.py
(ROUGH_CASES); against Mitsuba: tests/test_mitsuba_parity.py.
"""
import numpy as np
import pytest

import clrender
from clrender import layout
from clrender.arrays import build_scene_arrays
from clrender.conductor_presets import CONDUCTOR_PRESETS
from conftest import build_test_kernels, camera
from test_dielectric import Bsdf, direction, scene_with


@pytest.fixture(scope="module")
def kernels(context):
    return build_test_kernels(context, DIELECTRIC=1)


def fresnel_reference(cos_i, eta, k):
    """Unpolarised reflectance of a conductor of index eta + i k from the complex Fresnel
    amplitudes (Born and Wolf), in complex128: a different formula from the kernel's."""
    n = eta + 1j * k
    cos_t = np.sqrt(1 - (1 - cos_i ** 2) / n ** 2 + 0j)
    r_s = (cos_i - n * cos_t) / (cos_i + n * cos_t)
    r_p = (n * cos_i - cos_t) / (n * cos_i + cos_t)
    return (np.abs(r_s) ** 2 + np.abs(r_p) ** 2) / 2


COSINES = np.array([1.0, 0.95, 0.8, 0.6, 0.4, 0.2, 0.1, 0.03, 0.005])


@pytest.mark.parametrize("eta,k", [(CONDUCTOR_PRESETS["Au"]), (CONDUCTOR_PRESETS["Al"]),
                                   ([0.2, 0.92, 1.1], [3.9, 2.45, 2.14]), ([1.5, 2.0, 0.5], [0.0, 0.3, 0.0])],
                         ids=["Au", "Al", "eta-k", "weakly-absorbing"])
def test_smooth_conductor_reflects_its_fresnel_reflectance(context, queue, kernels, eta, k):
    # The weight of the delta lobe is tint x F(cos) per channel, F from the complex amplitudes.
    tint = np.array([0.9, 0.7, 0.5])
    bsdf = Bsdf(context, queue, kernels, {"type": "conductor", "tint": tint.tolist(), "eta": list(eta), "k": list(k)})
    for c in COSINES:
        wi, pdf, weight, _, delta = bsdf.sample(direction(c, 0.5), 4)
        assert np.all(delta) and np.all(pdf == 1)
        np.testing.assert_allclose(wi, np.broadcast_to(direction(c, 0.5) * [-1, -1, 1], wi.shape), atol=1e-6)
        expected = tint * fresnel_reference(c, np.array(eta), np.array(k))
        np.testing.assert_allclose(weight, np.broadcast_to(expected, weight.shape), rtol=3e-5, atol=1e-6, err_msg=c)


def test_zero_index_channels_reflect_everything(context, queue, kernels):
    # eta = k = 0 (a tint-only conductor; Mitsuba's AlSb preset in red) is a perfect mirror at
    # every angle, normal incidence included (where the formula is 0 / 0), exactly.
    tint = [0.9, 0.5, 0.25]
    for material in ({"type": "conductor", "tint": tint}, {"type": "conductor", "tint": tint, "material": "AlSb"}):
        bsdf = Bsdf(context, queue, kernels, material)
        for c in COSINES:
            _, _, weight, _, _ = bsdf.sample(direction(c, 0.5), 2)
            assert np.all(np.isfinite(weight))
            assert np.all(weight[:, 0] == np.float32(0.9)), (material, c)
            if "material" not in material:
                assert np.all(weight == np.float32(tint)), c


@pytest.mark.parametrize("material", [
    {"type": "conductor", "material": "Cu", "roughness": 0.5, "distribution": "beckmann", "masking": "separable"},
    {"type": "conductor", "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.1], "roughness": 0.7},
    {"type": "dielectric", "ior": 1.5, "roughness": 0.6, "distribution": "beckmann", "masking": "separable",
     "reflection_tint": [0.5, 0.7, 0.9]},
    {"type": "dielectric", "ior": 1.33, "roughness": 0.4},
], ids=["beckmann-copper", "ggx-eta-k", "beckmann-glass", "ggx-glass"])
def test_rough_lobes_are_reciprocal(context, queue, kernels, material):
    # Without energy compensation (which scales by a function of wo only) f(wo, wi) = f(wi, wo)
    # for reflection; across a dielectric interface f(wo -> wi) eta_o^2 = f(wi -> wo) eta_i^2,
    # the radiance 1/eta^2 of the transmitted direction included (eval is f * |cos wi|).
    bsdf = Bsdf(context, queue, kernels, dict(material, energy_compensation=False))
    # Pairs where the lobes are not negligible: 8 directions wo, 50 sampled wi each.
    wo, wi = [], []
    for n, cos_o in enumerate(np.linspace(0.1, 1.0, 8)):
        sampled, pdf, _, _, _ = bsdf.sample(direction(cos_o, n), 50, seed=n)
        wi.append(sampled[pdf > 0])
        wo.append(np.broadcast_to(direction(cos_o, n), wi[-1].shape))
    wo, wi = np.concatenate(wo).astype(float), np.concatenate(wi).astype(float)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    forward = np.array([bsdf.eval(o, i[None])[0][0] for o, i in zip(wo, wi)])
    outside = wi[:, 2] > 0
    ior = material.get("ior", 1.0)
    backward = np.empty_like(forward)
    for n, (o, i) in enumerate(zip(wo, wi)):
        if outside[n]:
            backward[n] = bsdf.eval(i, o[None])[0][0]
        else:   # wi inside, seen from there: not front-facing, the frame turned over (isotropic lobes)
            backward[n] = bsdf.eval(-i, -o[None], front_face=False)[0][0]
    cos_o, cos_i = np.abs(wo[:, 2]), np.abs(wi[:, 2])
    f_forward, f_backward = forward / cos_i[:, None], backward / cos_o[:, None]
    assert np.count_nonzero(f_forward[:, 0] > 0) > 300
    if material["type"] == "dielectric":
        assert np.count_nonzero(f_forward[~outside, 0] > 0) > 100
    np.testing.assert_allclose(f_forward, f_backward / np.where(outside, 1.0, ior ** 2)[:, None], rtol=3e-4, atol=1e-6)


def test_conductor_fields_reach_the_material_records():
    scene = clrender.load_scene_dict({
        "camera": camera(),
        "materials": [{"name": "gold", "type": "conductor", "material": "Au", "roughness": 0.2},
                      {"name": "metal", "type": "conductor", "eta": [0.2, 0.9, 1.1], "k": 3.0},
                      {"name": "mirror", "type": "conductor", "tint": [0.5, 0.5, 0.5]}],
        "shapes": [{"type": "sphere", "material": name} for name in ("gold", "metal", "mirror")]})
    records = build_scene_arrays(scene).materials
    field = lambda name: layout.field(records, layout.MATERIAL_FIELDS, name)  # noqa: E731
    np.testing.assert_array_equal(field("conductor_eta"), np.float32([CONDUCTOR_PRESETS["Au"][0], [0.2, 0.9, 1.1], [0, 0, 0]]))
    np.testing.assert_array_equal(field("conductor_k"), np.float32([CONDUCTOR_PRESETS["Au"][1], [3, 3, 3], [0, 0, 0]]))


@pytest.mark.parametrize("fields,message", [
    ({"material": "Au", "eta": 1.0}, "materials[0]: give either material or eta and k"),
    ({"material": "Unobtainium"}, "materials[0].material: unknown value 'Unobtainium'; valid: Ag, Al"),
    ({"eta": [0.2, 0.9, 1.1]}, "materials[0].k: required with eta"),
    ({"k": 2.0}, "materials[0].eta: required with k"),
    ({"eta": [0.2, -0.9, 1.1], "k": 1.0}, "materials[0].eta: must be non-negative"),
    ({"distribution": "phong"}, "materials[0].distribution: unknown value 'phong'; valid: ggx, beckmann"),
    ({"masking": "smith"}, "materials[0].masking: unknown value 'smith'; valid: height_correlated, separable"),
])
def test_invalid_conductor_fields_are_reported_with_their_place(fields, message):
    with pytest.raises(clrender.SceneError) as error:
        clrender.load_scene_dict(scene_with({"type": "conductor", **fields}))
    assert str(error.value).startswith(message), str(error.value)
