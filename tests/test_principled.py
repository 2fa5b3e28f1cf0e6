"""The principled material: Mitsuba 3.9's principled BSDF (kernels/materials/principled.h).

Values and densities are compared with Mitsuba's own `eval` and `pdf` (scalar_rgb) on the same
directions, through the BSDF dispatch the integrator uses (kernels/tests.cl, a surface point whose
normals are +z). The sampler is checked against our pdf by chi-square, as in test_dielectric.py
(chi2 < dof + 5 sqrt(2 dof); fixed seeds).
"""
import numpy as np
import pytest

import clrender
from clrender import features, layout, mitsuba
from clrender.arrays import build_scene_arrays
from clrender.principled import eta_from_specular
from conftest import build_test_kernels, camera, float32_rtol
from test_dielectric import Bsdf, check_sampling, direction, uniform_sphere
from test_dielectric import test_grazing_and_degenerate_directions_stay_finite as check_finite

try:
    import mitsuba as mi
except ImportError:
    mi = None

needs_mitsuba = pytest.mark.skipif(mi is None, reason="Mitsuba 3 is not installed (pip install -e '.[peers]')")

# Parameter sets, named as Mitsuba names them (the JSON format uses the same names).
CASES = {
    "defaults": {},
    "diffuse": {"base_color": [0.8, 0.3, 0.1], "roughness": 0.9},
    "retro-flat": {"base_color": [0.2, 0.6, 0.9], "roughness": 0.7, "flatness": 0.6},
    "anisotropic": {"base_color": [0.9, 0.8, 0.2], "roughness": 0.4, "anisotropic": 0.9},
    "metal": {"base_color": [0.95, 0.6, 0.3], "roughness": 0.3, "metallic": 1.0, "anisotropic": 0.5},
    "half-metal": {"base_color": [0.5, 0.7, 0.2], "roughness": 0.5, "metallic": 0.5, "spec_tint": 0.7},
    "glass": {"base_color": [0.9, 0.95, 0.7], "roughness": 0.3, "spec_trans": 1.0, "eta": 1.33},
    "frosted": {"base_color": [0.6, 0.8, 0.9], "roughness": 0.6, "spec_trans": 0.6, "metallic": 0.2,
                "specular": 0.8, "anisotropic": 0.4},
    "bubble": {"roughness": 0.4, "spec_trans": 0.8, "eta": 0.8, "clearcoat": 0.5},
    "sheen": {"base_color": [0.3, 0.1, 0.6], "sheen": 1.0, "sheen_tint": 0.6, "roughness": 0.8},
    "clearcoat": {"base_color": [0.1, 0.2, 0.5], "roughness": 0.6, "clearcoat": 1.0, "clearcoat_gloss": 0.4},
    "glossy-coat": {"base_color": [0.7, 0.1, 0.1], "roughness": 0.2, "clearcoat": 0.8, "clearcoat_gloss": 0.9,
                    "specular": 0.3},
    "everything": {"base_color": [0.4, 0.8, 0.3], "roughness": 0.45, "anisotropic": 0.6, "metallic": 0.3,
                   "spec_trans": 0.4, "spec_tint": 0.5, "sheen": 0.7, "sheen_tint": 0.4, "clearcoat": 0.6,
                   "clearcoat_gloss": 0.5, "flatness": 0.3, "eta": 1.7},
    "rates": {"roughness": 0.5, "clearcoat": 0.5, "spec_trans": 0.3, "main_specular_sampling_rate": 0.3,
              "clearcoat_sampling_rate": 2.0, "diffuse_reflectance_sampling_rate": 0.7},
    "mirror-like": {"base_color": [0.9, 0.9, 0.9], "roughness": 0.0, "metallic": 0.8},
}


@pytest.fixture(scope="module")
def kernels(context):
    return build_test_kernels(context, DIELECTRIC=1)


def material(params):
    return {"type": "principled", **params}


# --------------------------------------------------------------------------------------------
# Scene files: fields, defaults, validation, features
# --------------------------------------------------------------------------------------------
def scene_with(*materials, textures=()):
    return {"camera": camera(), "textures": list(textures),
            "materials": [dict(m, name=f"m{i}") for i, m in enumerate(materials)],
            "shapes": [{"type": "sphere", "material": f"m{i}", "center": [i, 0, 0]} for i in range(len(materials))]}


def test_fields_reach_the_material_record():
    scene = clrender.load_scene_dict(scene_with(material({}), material(CASES["everything"]),
                                                material({"specular": 0.3, "metallic": {"texture": "t"}}),
                                                textures=[{"name": "t", "type": "checkerboard"}]))
    records = build_scene_arrays(scene).materials
    field = lambda name, i: layout.field(records, layout.MATERIAL_FIELDS, name)[i]  # noqa: E731
    assert field("kind", 0) == layout.MATERIAL_KINDS["principled"] and field("albedo_tables", 0) == -1
    # Mitsuba's defaults: base_color 0.5, roughness 0.5, specular 0.5 (eta 1.5), weights 0, rates 1.
    np.testing.assert_allclose(field("color", 0), 0.5)
    assert [field(f"principled_{name}", 0) for name in ("roughness", "eta", "specular_rate", "clearcoat_rate",
                                                        "diffuse_rate")] == [0.5, 1.5, 1.0, 1.0, 1.0]
    assert all(field(f"principled_{name}", 0) == 0 for name in layout.PRINCIPLED_WEIGHTS)
    everything = CASES["everything"]
    np.testing.assert_allclose(field("color", 1), everything["base_color"])
    for name in ("roughness", "eta", *layout.PRINCIPLED_WEIGHTS):
        assert field(f"principled_{name}", 1) == np.float32(everything[name]), name
    assert field("principled_eta", 2) == np.float32(eta_from_specular(0.3))
    # A textured weight: its lane w names the texture (as a number), the others hold constants.
    member = layout.MATERIAL_FIELDS["principled_metallic"][0]
    assert layout.member_lanes(records, member)[2, 3] == layout.texture_reference(0, True)
    assert layout.member_lanes(records, layout.MATERIAL_FIELDS["principled_sheen"][0])[2, 3] == layout.TEXTURE_REF_NONE


@pytest.mark.parametrize("fields,message", [
    ({"metallic": 1.5}, "materials[0].metallic: must be <= 1"),
    ({"roughness": -0.1}, "materials[0].roughness: must be >= 0"),
    ({"base_color": [1.2, 0, 0]}, "materials[0].base_color: must be <= 1 per channel"),
    ({"eta": 0}, "materials[0].eta: must be > 0"),
    ({"eta": 1.4, "specular": 0.5}, "materials[0]: give either eta or specular"),
    ({"specular": 12.5}, "materials[0].specular: must be < 12.5"),
    ({"specular": -0.1}, "materials[0].specular: must be >= 0"),
    ({"eta": 1.0, "spec_trans": 0.5}, "materials[0].eta: an index of 1 with spec_trans"),
    ({"specular": 0.0, "spec_trans": {"texture": "t"}}, "materials[0].specular: an index of 1 with spec_trans"),
    ({"clearcoat_sampling_rate": 0}, "materials[0].clearcoat_sampling_rate: must be > 0"),
    ({"sheen": {"texture": "nope"}}, "materials[0].sheen.texture: unknown texture 'nope'"),
    ({"ior": 1.5}, "materials[0].ior: unknown field"),
])
def test_invalid_fields_are_reported_with_their_place(fields, message):
    with pytest.raises(clrender.SceneError) as error:
        clrender.load_scene_dict(scene_with(material(fields), textures=[{"name": "t", "type": "checkerboard"}]))
    assert str(error.value).startswith(message), str(error.value)


def test_principled_needs_the_glossy_build_and_uv_only_when_anisotropic():
    def needed(*materials, **extra):
        scene = clrender.load_scene_dict(scene_with(*materials, **extra))
        return features.scene_features(scene, packets=True)
    isotropic = needed(material({"metallic": 0.5}))
    assert isotropic["DIELECTRIC"] == 1 and isotropic["TEXTURES"] == 0 and isotropic["LANES"] == 1
    assert needed(material({"anisotropic": 0.3}))["TEXTURES"] == 1
    assert needed(material({"anisotropic": {"texture": "t"}}), textures=[{"name": "t", "type": "checkerboard"}])["TEXTURES"] == 1


def test_mitsuba_xml_reads_every_parameter(tmp_path):
    path = tmp_path / "scene.xml"
    path.write_text("""<scene version="3.0.0">
    <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
    <shape type="sphere">
        <bsdf type="principled">
            <rgb name="base_color" value="0.2, 0.8, 0.1"/>
            <float name="roughness" value="0.15"/>
            <texture name="anisotropic" type="checkerboard"><float name="color0" value="0.05"/></texture>
            <float name="metallic" value="0.2"/> <float name="spec_trans" value="0.3"/>
            <float name="spec_tint" value="0.4"/> <float name="sheen" value="0.5"/>
            <float name="sheen_tint" value="0.6"/> <float name="clearcoat" value="0.7"/>
            <float name="clearcoat_gloss" value="0.8"/> <float name="flatness" value="0.9"/>
            <float name="specular" value="0.7"/>
            <float name="main_specular_sampling_rate" value="2"/>
            <float name="clearcoat_sampling_rate" value="3"/>
            <float name="diffuse_reflectance_sampling_rate" value="4"/>
        </bsdf>
    </shape>
</scene>""")
    (m,) = mitsuba.read_scene(path).scene["materials"]
    assert m == {"name": "bsdf_line4", "type": "principled", "base_color": [0.2, 0.8, 0.1], "roughness": 0.15,
                 "anisotropic": {"texture": "checkerboard_line7"}, "metallic": 0.2, "spec_trans": 0.3,
                 "spec_tint": 0.4, "sheen": 0.5, "sheen_tint": 0.6, "clearcoat": 0.7, "clearcoat_gloss": 0.8,
                 "flatness": 0.9, "specular": 0.7, "main_specular_sampling_rate": 2.0, "clearcoat_sampling_rate": 3.0,
                 "diffuse_reflectance_sampling_rate": 4.0}
    path.write_text(path.read_text().replace('<float name="flatness" value="0.9"/>', '<float name="eta" value="1.3"/>'))
    with pytest.raises(clrender.MitsubaXmlError, match=r"scene.xml:4 <bsdf type='principled'>: give either eta or specular"):
        clrender.load_scene(path)


def mitsuba_bsdf(params):
    """Mitsuba's principled BSDF with these parameters."""
    d = {"type": "principled"}
    for key, value in params.items():
        d[key] = {"type": "rgb", "value": value} if key == "base_color" else value
    return mi.load_dict(d)


def mitsuba_local(v, front_face):
    """Directions of the test surface point in Mitsuba's local frame: its shading frame is
    (x, y, z) from the front, (x, -y, -z) from behind (normal -z: wo is inside)."""
    return v if front_face else v * np.array([1.0, -1.0, -1.0])


def mitsuba_eval_pdf(bsdf, wo, wi):
    """Mitsuba's eval (f |cos|, radiance) and pdf for our (wo, wi) = its (si.wi, wo), local."""
    ctx = mi.BSDFContext()
    values, pdfs = np.zeros((len(wo), 3)), np.zeros(len(wo))
    for k, (o, i) in enumerate(zip(wo, wi)):
        si = mi.SurfaceInteraction3f()
        si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
        si.wi = mi.Vector3f(*o)
        value = bsdf.eval(ctx, si, mi.Vector3f(*i))
        values[k] = [value[0], value[1], value[2]]
        pdfs[k] = bsdf.pdf(ctx, si, mi.Vector3f(*i))
    return values, pdfs


def direction_pairs(bsdf, front_face, seed):
    """wo over the hemisphere (grazing included), wi uniform over the sphere, and wi sampled by
    our sampler (the lobes' peaks, transmission included)."""
    rng = np.random.default_rng(seed)
    wo = uniform_sphere(300, rng)
    wo[:, 2] = np.abs(wo[:, 2])
    wo[:10, 2] = 1e-3
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi = uniform_sphere(300, rng)
    sampled_wo = np.repeat(wo[::10], 10, axis=0)
    sampled = np.concatenate([bsdf.sample(o, 10, front_face=front_face, seed=seed + k)[0]
                              for k, o in enumerate(wo[::10])])
    keep = np.linalg.norm(sampled, axis=1) > 0.5   # (no sample: the zero vector)
    return np.concatenate([wo, sampled_wo[keep]]), np.concatenate([wi, sampled[keep]])


@needs_mitsuba
@pytest.mark.parametrize("front_face", [True, False], ids=["outside", "inside"])
@pytest.mark.parametrize("name", sorted(CASES))
def test_eval_and_pdf_match_mitsuba(device, context, queue, kernels, name, front_face):
    mi.set_variant("scalar_rgb")
    params = CASES[name]
    bsdf = Bsdf(context, queue, kernels, material(params))
    wo, wi = direction_pairs(bsdf, front_face, seed=len(name))
    value, pdf = bsdf.eval(wo, wi, front_face=front_face)
    theirs_value, theirs_pdf = mitsuba_eval_pdf(mitsuba_bsdf(params), mitsuba_local(wo, front_face),
                                                mitsuba_local(wi, front_face))
    # Mitsuba's pdf where its value is 0 (a black back face without transmission) is no density
    # that matters; ours is 0 there.
    black = np.all(theirs_value == 0, axis=1)
    assert np.all(value[black] == 0)
    theirs_pdf[black & ~np.any(value > 0, axis=1)] = 0
    # float32 in both, in different orders: 2e-4 relative (on the sharpest lobes, where the
    # half-vector's rounding is amplified), and 1e-6 of the largest value where terms cancel.
    rtol = float32_rtol(device, 2e-4)
    np.testing.assert_allclose(value, theirs_value, rtol=rtol, atol=1e-6 * theirs_value.max())
    np.testing.assert_allclose(pdf, theirs_pdf, rtol=rtol, atol=1e-6 * theirs_pdf.max())


@needs_mitsuba
@pytest.mark.parametrize("front_face", [True, False], ids=["outside", "inside"])
def test_anisotropy_follows_dp_du_as_in_mitsuba(context, queue, front_face):
    # With uv (TEXTURES), Mitsuba's shading frame: s = dp/du projected onto the shading normal's
    # plane, t = n x s, n the outward shading normal. Here dp/du = x and the shading normal is
    # tilted; directions where the facet and the shading normal disagree are ours to drop
    # (light leaks), so they are left out.
    mi.set_variant("scalar_rgb")
    params = CASES["everything"]
    kernels = build_test_kernels(context, DIELECTRIC=1, TEXTURES=1)
    bsdf = Bsdf(context, queue, kernels, material(params))
    ns = np.array([0.3, -0.2, 1.0]) / np.linalg.norm([0.3, -0.2, 1.0])
    n = ns if front_face else -ns
    s = np.array([1.0, 0.0, 0.0]) - n * n[0]
    s /= np.linalg.norm(s)
    frame = np.stack([s, np.cross(n, s), n])
    rng = np.random.default_rng(4)
    wo = uniform_sphere(800, rng)
    wo = wo[(wo[:, 2] > 0) & (wo @ ns > 0)]     # (the side the test point's normals face)
    wi = uniform_sphere(len(wo), rng)
    agree = (wi @ ns) * wi[:, 2] > 0
    value, pdf = bsdf.eval(wo, wi, front_face=front_face, ns=ns)
    theirs_value, theirs_pdf = mitsuba_eval_pdf(mitsuba_bsdf(params), wo @ frame.T, wi @ frame.T)
    assert np.all(value[~agree] == 0)
    np.testing.assert_allclose(value[agree], theirs_value[agree], rtol=2e-4, atol=1e-6 * theirs_value.max())
    np.testing.assert_allclose(pdf[agree], theirs_pdf[agree], rtol=2e-4, atol=1e-6 * theirs_pdf.max())


QUADRATURE = 18
SAMPLING_CASES = [("everything", True, 0.7), ("everything", False, 0.6), ("glass", True, 0.4),
                  ("glass", False, 0.8), ("bubble", True, 0.5), ("bubble", False, 0.9), ("anisotropic", True, 0.3),
                  ("metal", True, 0.9), ("clearcoat", True, 0.5), ("rates", True, 0.6), ("retro-flat", True, 0.2),
                  ("frosted", False, 0.3)]


@pytest.mark.parametrize("name,front_face,cos_o", SAMPLING_CASES,
                         ids=[f"{n}-{'out' if f else 'in'}-{c}" for n, f, c in SAMPLING_CASES])
def test_sampling_follows_the_pdf_and_weights_are_eval_over_pdf(context, queue, kernels, name, front_face, cos_o):
    # The lobes refracted into the denser side are narrow: 18 x 18 points per bin integrate
    # them to 0.2%.
    params = CASES[name]
    bsdf = Bsdf(context, queue, kernels, material(params))
    wi, _, eta, valid = check_sampling(bsdf, direction(cos_o, 0.9), front_face, seed=7, sub=QUADRATURE)
    # A transmitted sample carries the relative index it crossed.
    eta_in = eta_from_specular(params["specular"]) if "specular" in params else params.get("eta", 1.5)
    crossed = wi[:, 2] < 0
    expected_eta = np.where(crossed, eta_in if front_face else 1 / eta_in, 1.0)
    np.testing.assert_allclose(eta[valid], expected_eta[valid], rtol=1e-6)
    assert np.any(crossed[valid]) == (params.get("spec_trans", 0) > 0)


@pytest.mark.parametrize("name", ["everything", "glass", "bubble", "mirror-like", "anisotropic", "rates"])
def test_grazing_and_degenerate_directions_stay_finite(context, queue, kernels, name):
    # As for the dielectrics: cos(wo) down to 0 exactly, wi grazing or opposite, tilted normals.
    check_finite(context, queue, kernels, material(CASES[name]))


PRINCIPLED_SPHERES = """
    <shape type="sphere">
        <float name="radius" value="0.7"/>
        <transform name="to_world"><rotate x="1" angle="50"/><rotate z="1" angle="30"/><translate x="-1.1"/></transform>
        <bsdf type="principled">
            <rgb name="base_color" value="0.9, 0.6, 0.3"/>
            <float name="metallic" value="1"/>
            <float name="roughness" value="0.35"/>
            <float name="anisotropic" value="0.9"/>
        </bsdf>
    </shape>
    <shape type="sphere">
        <float name="radius" value="0.6"/>
        <transform name="to_world"><translate y="-0.3"/></transform>
        <bsdf type="principled">
            <rgb name="base_color" value="0.8, 0.9, 1"/>
            <float name="spec_trans" value="0.9"/>
            <float name="roughness" value="0.25"/>
            <float name="eta" value="1.4"/>
        </bsdf>
    </shape>
    <shape type="sphere">
        <float name="radius" value="0.6"/>
        <transform name="to_world"><translate x="1.1" y="-0.3"/></transform>
        <bsdf type="principled">
            <rgb name="base_color" value="0.2, 0.5, 0.9"/>
            <float name="roughness" value="0.6"/>
            <float name="sheen" value="0.8"/>
            <float name="sheen_tint" value="0.5"/>
            <float name="clearcoat" value="1"/>
            <float name="clearcoat_gloss" value="0.7"/>
            <float name="flatness" value="0.5"/>
            <float name="specular" value="0.3"/>
        </bsdf>
    </shape>"""


@needs_mitsuba
def test_principled_spheres_render_as_in_mitsuba(tmp_path, device):
    # Analytic spheres (Mitsuba's sphere uv and dp/du, turned by to_world, give the anisotropic
    # metal's tangents), a principled glass and a coated, sheened diffuse, on a floor under a sun
    # and a sky; compared as tests/test_mitsuba_parity.py compares images.
    mi.set_variant("scalar_rgb")
    from mitsuba_scenes import FLOOR, SKY, SUN, _scene
    from test_mitsuba_parity import assert_same_image, render_both
    path = tmp_path / "principled.xml"
    path.write_text(_scene(FLOOR + SUN + SKY + PRINCIPLED_SPHERES, max_depth=6))
    ours, mitsuba = render_both(path, device, spp=64, res=24)
    assert_same_image(ours, mitsuba)
