"""Thin dielectric sheets (kernels/materials/thin_dielectric.h) and the reflection tint of
dielectrics (Mitsuba's specular_reflectance). Statistical checks: 5 standard errors, fixed seeds
(tests/test_dielectric.py). Against Mitsuba: tests/test_mitsuba_parity.py (thin_pane,
beckmann_glass).
"""
import numpy as np
import pytest

import clrender
from clrender import layout
from clrender.arrays import build_scene_arrays
from conftest import build_test_kernels, camera, z_bound
from test_dielectric import DEEP, Bsdf, direction, fresnel_reference, furnace_scene, scene_with


@pytest.fixture(scope="module")
def kernels(context):
    return build_test_kernels(context, DIELECTRIC=1)


def sheet_reflectance(cos_i, eta):
    """R' = R + T^2 R / (1 - R^2): the sheet's reflections summed incoherently (float64)."""
    r = fresnel_reference(abs(cos_i), eta)[0]
    return r + (1 - r) ** 2 * r / (1 - r * r) if r < 1 else 1.0


@pytest.mark.parametrize("ior,exterior", [(1.5, 1.0), (1.33, 1.0), (1.0, 1.5)])
@pytest.mark.parametrize("front_face", [True, False])
def test_thin_sheet_reflects_its_summed_reflectance_and_passes_straight_through(context, queue, kernels, ior,
                                                                                 exterior, front_face):
    reflect_tint, tint = np.array([0.9, 0.8, 0.7]), np.array([0.6, 0.8, 1.0])
    bsdf = Bsdf(context, queue, kernels, {"type": "thin_dielectric", "ior": ior, "exterior_ior": exterior,
                                          "tint": tint.tolist(), "reflection_tint": reflect_tint.tolist()})
    count = 20000
    for c in (1.0, 0.7, 0.3, 0.05):
        wo = direction(c, 0.4)
        wi, pdf, weight, eta, delta = bsdf.sample(wo, count, front_face=front_face, seed=3)
        assert np.all(delta) and np.all(eta == 1)   # the same medium on both sides: no eta^2
        r = sheet_reflectance(c, ior / exterior)
        reflected = wi[:, 2] > 0
        # Binomial count of reflections within 5 standard errors.
        assert abs(reflected.mean() - r) <= 5 * np.sqrt(r * (1 - r) / count) + 1e-6, (c, r)
        np.testing.assert_allclose(pdf[reflected], r, rtol=1e-5)
        np.testing.assert_allclose(wi[reflected], np.broadcast_to(wo * [-1, -1, 1], wi[reflected].shape), atol=1e-6)
        np.testing.assert_array_equal(weight[reflected], np.broadcast_to(np.float32(reflect_tint), weight[reflected].shape))
        if r < 1:
            np.testing.assert_allclose(pdf[~reflected], 1 - r, rtol=1e-4)
            np.testing.assert_array_equal(wi[~reflected], np.broadcast_to(-np.float32(wo), wi[~reflected].shape))
            np.testing.assert_array_equal(weight[~reflected], np.broadcast_to(np.float32(tint), weight[~reflected].shape))
        # A delta BSDF: nothing for directions chosen elsewhere.
        f, p = bsdf.eval(wo, np.array([wo * [-1, -1, 1], -wo, [0, 0, 1]]), front_face=front_face)
        assert np.all(f == 0) and np.all(p == 0)


def test_sheet_transmits_what_a_slab_does_at_normal_incidence():
    # T' = 1 - R' = (1 - R) / (1 + R): the closed form of the glass slab of test_dielectric.py.
    for ior in (1.2, 1.5, 2.4):
        r = ((ior - 1) / (ior + 1)) ** 2
        assert 1 - sheet_reflectance(1.0, ior) == pytest.approx((1 - r) / (1 + r), rel=1e-12)


@pytest.mark.parametrize("material", [{"type": "thin_dielectric", "ior": 1.5},
                                      {"type": "thin_dielectric", "ior": 1.1, "exterior_ior": 1.4}],
                         ids=["glass", "inverted"])
def test_thin_sphere_vanishes_in_a_furnace_exactly(device, material):
    # Lossless untinted lobes weigh exactly 1: every sample of every pixel is the environment.
    result = clrender.Renderer(furnace_scene(material), device).render(spp=16, seed=1, max_depth=DEEP, rr_depth=DEEP)
    np.testing.assert_allclose(result.image, 1.0, atol=1e-6)


def test_pane_in_front_of_an_emitter_transmits_its_summed_transmittance(device):
    # A camera looks through a pane at normal incidence at an emitter (nothing else): each path
    # passes (weight tint) or reflects into the void, so the image is radiance x tint x T'.
    radiance, tint = 2.0, np.array([0.9, 0.6, 0.3])
    scene = clrender.load_scene_dict({
        "camera": camera(position=(0, 0, 4), look_at=(0, 0, 0), fov=4, resolution=(12, 12)),
        "materials": [{"name": "pane", "type": "thin_dielectric", "ior": 1.5, "tint": tint.tolist()},
                      {"name": "lamp", "type": "emissive", "radiance": radiance}],
        "shapes": [{"type": "rectangle", "material": "pane"},
                   {"type": "rectangle", "material": "lamp", "transform": {"scale": [2, 2, 1], "translate": [0, 0, -1]}}]})
    result = clrender.Renderer(scene, device).render(spp=128, seed=4)
    expected = radiance * tint * (1 - sheet_reflectance(1.0, 1.5))
    for channel in range(3):
        assert z_bound(result.image[..., channel], expected[channel]) < 5.0


@pytest.mark.parametrize("roughness", [0.0, 0.5])
def test_dielectric_reflection_is_tinted(context, queue, kernels, roughness):
    # Reflection weighs reflection_tint (smooth: exactly; rough: f / pdf of reflected samples is
    # that of the untinted lobe times the tint), transmission is untouched.
    reflect_tint = np.array([0.3, 0.5, 0.7])
    base = {"type": "dielectric", "ior": 1.5, "roughness": roughness, "energy_compensation": False}
    plain = Bsdf(context, queue, kernels, base)
    tinted = Bsdf(context, queue, kernels, dict(base, reflection_tint=reflect_tint.tolist()))
    wo = direction(0.3, 0.2)
    wi_a, _, weight_a, _, _ = plain.sample(wo, 5000, seed=8)
    wi_b, _, weight_b, _, _ = tinted.sample(wo, 5000, seed=8)
    np.testing.assert_array_equal(wi_a, wi_b)
    reflected = wi_a[:, 2] > 0
    assert 100 < reflected.sum() < 4900
    np.testing.assert_allclose(weight_b[reflected], weight_a[reflected] * reflect_tint, rtol=1e-6)
    np.testing.assert_array_equal(weight_b[~reflected], weight_a[~reflected])


def test_thin_and_tinted_dielectric_fields_reach_the_material_records():
    scene = clrender.load_scene_dict({
        "camera": camera(),
        "materials": [{"name": "pane", "type": "thin_dielectric", "ior": 1.6, "exterior_ior": 1.1,
                       "tint": [0.9, 0.8, 0.7], "reflection_tint": [0.5, 0.6, 0.7]},
                      {"name": "glass", "type": "dielectric", "reflection_tint": 0.5},
                      {"name": "painted", "type": "thin_dielectric", "reflection_tint": {"texture": "checks"}}],
        "textures": [{"name": "checks", "type": "checkerboard"}],
        "shapes": [{"type": "sphere", "material": name} for name in ("pane", "glass", "painted")]})
    records = build_scene_arrays(scene).materials
    member, _, _ = layout.MATERIAL_FIELDS["reflection_tint"]
    assert layout.member_lanes(records, member)[:, 3].tolist() == [-1, -1, layout.texture_reference(0, False)]
    records = records[:2]
    field = lambda name: layout.field(records, layout.MATERIAL_FIELDS, name)  # noqa: E731
    assert field("kind").tolist() == [layout.MATERIAL_KINDS["thin_dielectric"], layout.MATERIAL_KINDS["dielectric"]]
    np.testing.assert_allclose(field("ior"), [1.6, 1.5], rtol=1e-7)
    np.testing.assert_allclose(field("exterior_ior"), [1.1, 1.0], rtol=1e-7)
    np.testing.assert_allclose(field("color")[0], [0.9, 0.8, 0.7], rtol=1e-7)
    np.testing.assert_allclose(field("reflection_tint"), [[0.5, 0.6, 0.7], [0.5, 0.5, 0.5]], rtol=1e-7)
    assert field("albedo_tables").tolist() == [-1, -1]


@pytest.mark.parametrize("material,message", [
    ({"type": "thin_dielectric", "roughness": 0.2}, "materials[0].roughness: unknown field"),
    ({"type": "thin_dielectric", "ior": 0}, "materials[0].ior: must be > 0"),
    ({"type": "thin_dielectric", "reflection_tint": [1.2, 1, 1]}, "materials[0].reflection_tint: must be <= 1"),
    ({"type": "dielectric", "reflection_tint": [0.5, -1, 1]}, "materials[0].reflection_tint: must be non-negative"),
    ({"type": "conductor", "reflection_tint": 0.5}, "materials[0].reflection_tint: unknown field"),
])
def test_invalid_thin_dielectric_fields_are_reported_with_their_place(material, message):
    with pytest.raises(clrender.SceneError) as error:
        clrender.load_scene_dict(scene_with(material))
    assert str(error.value).startswith(message), str(error.value)
