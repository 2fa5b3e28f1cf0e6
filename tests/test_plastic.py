"""Plastic: Mitsuba 3.9's plastic and roughplastic (kernels/materials/plastic.h, plastic_coat.h,
clrender/plastic.py), checked against Mitsuba itself (scalar_rgb: its eval, pdf and sample at
chosen directions, and the coat tables read back through its eval), and against their own
densities (chi-square: chi2 < dof + 5 sqrt(2 dof)). Statistical checks use fixed seeds and 5
standard errors (conftest.z_bound).
"""
import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender import layout, plastic, textures
from clrender.arrays import build_scene_arrays
from clrender.energy import fill_albedo_tables
from conftest import build_test_kernels, camera
from test_dielectric import Bsdf, assert_samples_follow_the_density, direction

mi = pytest.importorskip("mitsuba")
SIZE = layout.COAT_TABLE_SIZE


@pytest.fixture(scope="module", autouse=True)
def scalar_rgb():
    mi.set_variant("scalar_rgb")


@pytest.fixture(scope="module")
def kernels(context):
    return build_test_kernels(context, DIELECTRIC=1)


def scene_with(material, texture_list=()):
    return clrender.load_scene_dict({"camera": camera(), "materials": [dict(material, name="m", type="plastic")],
                                     "textures": list(texture_list), "shapes": [{"type": "sphere", "material": "m"}]})


def rgb(value):
    return {"type": "rgb", "value": list(value)}


def ours_bsdf(context, queue, kernels, material):
    return Bsdf(context, queue, kernels, dict(material, type="plastic"))


def their_bsdf(ours):
    """The Mitsuba BSDF of one of our plastic materials (a dict of the JSON format)."""
    props = {"type": "roughplastic" if "alpha" in ours else "plastic",
             "int_ior": ours.get("ior", 1.49), "ext_ior": ours.get("exterior_ior", 1.000277),
             "diffuse_reflectance": rgb(np.broadcast_to(ours.get("diffuse", 0.5), 3)),
             "specular_reflectance": rgb(np.broadcast_to(ours.get("specular", 1.0), 3)),
             "nonlinear": ours.get("nonlinear", False)}
    if "alpha" in ours:
        props.update(alpha=ours["alpha"], distribution=ours.get("distribution", "ggx"))
    return mi.load_dict(props)


def interaction(wo):
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*wo)   # Mitsuba's wi is our wo: towards the viewer
    return si


def hemisphere(count, rng, low=0.02):
    z = rng.uniform(low, 1, count)
    phi = rng.uniform(0, 2 * np.pi, count)
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


# --------------------------------------------------------------------------------------------
# Scene files: fields, defaults, validation
# --------------------------------------------------------------------------------------------
def test_fields_and_mitsubas_defaults_reach_the_material_record():
    scene = clrender.load_scene_dict({
        "camera": camera(),
        "materials": [{"name": "default", "type": "plastic"},
                      {"name": "rough", "type": "plastic", "alpha": 0.2, "distribution": "beckmann", "ior": 1.9,
                       "exterior_ior": 1.33, "diffuse": [0.1, 0.2, 0.9], "specular": 0.5, "nonlinear": True}],
        "shapes": [{"type": "sphere", "material": name} for name in ("default", "rough")]})
    records = build_scene_arrays(scene).materials
    field = lambda name: layout.field(records, layout.MATERIAL_FIELDS, name)  # noqa: E731
    assert field("kind").tolist() == [layout.MATERIAL_KINDS["plastic"]] * 2
    np.testing.assert_allclose(field("ior"), [1.49, 1.9], rtol=1e-7)   # polypropylene
    np.testing.assert_allclose(field("exterior_ior"), [1.000277, 1.33], rtol=1e-7)   # air
    np.testing.assert_allclose(field("color"), [[0.5] * 3, [0.1, 0.2, 0.9]], rtol=1e-7)
    np.testing.assert_allclose(field("reflection_tint"), [[1.0] * 3, [0.5] * 3])
    assert field("nonlinear").tolist() == [0, 1]
    np.testing.assert_allclose(field("alpha"), [0, 0.2], rtol=1e-6)
    assert field("distribution")[1] == layout.MICROFACET_DISTRIBUTIONS["beckmann"]
    assert field("masking").tolist() == [layout.MASKINGS["separable"]] * 2   # always Mitsuba's
    np.testing.assert_allclose(field("specular_sampling_weight"), [1 / 1.5, 0.5 / (0.5 + 0.4)], rtol=1e-6)
    # The smooth coat has no tables; the rough one a row of COAT_TABLE_SIZE + 1.
    assert field("albedo_tables").tolist() == [-1, 0]
    np.testing.assert_allclose(field("coat_alpha_range")[1], [0.2, 0.2], rtol=1e-6)


@pytest.mark.parametrize("field,value,message", [
    ("ior", 1.000277, "materials[0].ior: must differ from exterior_ior"),
    ("ior", 0, "materials[0].ior: must be > 0"),
    ("diffuse", [1.2, 1, 1], "materials[0].diffuse: must be <= 1 per channel"),
    ("specular", -0.5, "materials[0].specular: must be non-negative"),
    ("distribution", "phong", "materials[0].distribution: unknown value 'phong'"),
    ("masking", "separable", "materials[0].masking: unknown field"),
    ("tint", 0.5, "materials[0].tint: unknown field"),
])
def test_invalid_fields_are_reported_with_their_place(field, value, message):
    with pytest.raises(clrender.SceneError) as error:
        scene_with({field: value})
    assert str(error.value).startswith(message), str(error.value)


def write_png(path, pixels):
    bitmap = mi.Bitmap(np.ascontiguousarray(pixels, np.uint8), mi.Bitmap.PixelFormat.RGB)
    bitmap.write(str(path))
    return str(path)


def test_specular_sampling_weight_uses_mitsubas_texture_means(tmp_path):
    # Mitsuba's Texture::mean(): a bitmap's mean luminance, a checkerboard's and an RGB constant's
    # mean over channels.
    rng = np.random.default_rng(3)
    png = write_png(tmp_path / "t.png", rng.integers(0, 256, (4, 5, 3)))
    texture_list = [{"name": "png", "type": "bitmap", "file": png},
                    {"name": "checks", "type": "checkerboard", "color0": [0.8, 0.3, 0.1], "color1": 0.2}]
    checks = {"type": "checkerboard", "color0": rgb([0.8, 0.3, 0.1]), "color1": 0.2}
    for diffuse, theirs in [({"texture": "png"}, {"type": "bitmap", "filename": png}),
                            ({"texture": "checks"}, checks), ([0.2, 0.4, 0.9], rgb([0.2, 0.4, 0.9]))]:
        scene = scene_with({"diffuse": diffuse, "specular": {"texture": "checks"}}, texture_list)
        weight = layout.field(build_scene_arrays(scene).materials[0], layout.MATERIAL_FIELDS, "specular_sampling_weight")
        d, s = mi.load_dict(theirs).mean(), mi.load_dict(checks).mean()
        assert weight == pytest.approx(s / (s + d), rel=1e-5), diffuse


# --------------------------------------------------------------------------------------------
# The coat tables against Mitsuba's
# --------------------------------------------------------------------------------------------
def mitsuba_coat_tables(alpha, distribution, ior, exterior_ior):
    """Mitsuba's external transmittance T(mu_k) and internal reflectance r, read back through its
    eval: with specular_reflectance 0 only the diffuse lobe remains, d / (1 - r) / (pi eta^2)
    T(cos_o) T(cos_i) cos_i (nonlinear: d / (1 - d r)); the ratio of the two gives r, cos_o = 1 then
    T(1), and cos_o = mu_k T(mu_k) (a cosine of 1e-7 stands for mu_0 = 1e-6: Mitsuba needs cos > 0)."""
    def bsdf(nonlinear):
        return mi.load_dict({"type": "roughplastic", "alpha": alpha, "distribution": distribution,
                             "int_ior": ior, "ext_ior": exterior_ior, "nonlinear": nonlinear,
                             "specular_reflectance": 0.0, "diffuse_reflectance": 0.5})

    def value(b, cos_o, cos_i):
        return np.array(b.eval(mi.BSDFContext(), interaction(direction(cos_o)), mi.Vector3f(*direction(cos_i, 1.0))))[0]

    linear, nonlinear = bsdf(False), bsdf(True)
    ratio = value(linear, 1, 1) / value(nonlinear, 1, 1)
    r = (ratio - 1) / (ratio - 0.5)
    eta = np.float32(ior) / np.float32(exterior_ior)
    scale = 0.5 / (1 - r) / np.pi / eta ** 2
    t_normal = np.sqrt(value(linear, 1, 1) / scale)
    mu = np.linspace(0, 1, SIZE)
    return np.array([value(linear, max(m, 1e-7), 1.0) / (scale * t_normal) for m in mu]), r


def our_coat_tables(queue, material, texture_list=()):
    """The rows (T(mu_0..), r) of a plastic material's coat tables."""
    arrays = build_scene_arrays(scene_with(material, texture_list))
    fill_albedo_tables(queue, arrays)
    return arrays.specular_albedo.reshape(-1, SIZE + 1).astype(float)


COATS = [(0.1, "beckmann", 1.49, 1.000277), (0.3, "beckmann", 1.5, 1.0), (1.0, "beckmann", 1.5, 1.0),
         (0.2, "beckmann", 1.0, 1.5), (0.1, "ggx", 1.49, 1.000277), (0.01, "ggx", 1.5, 1.0),
         (0.7, "ggx", 1.5, 1.0), (0.2, "ggx", 1.0, 1.5), (0.05, "ggx", 2.0, 1.0), (0.001, "ggx", 1.5, 1.0)]


@pytest.mark.parametrize("alpha,distribution,ior,exterior_ior", COATS)
def test_coat_tables_are_mitsubas(queue, alpha, distribution, ior, exterior_ior):
    # The same quadrature of the same integrals; they differ by (measured, docs/materials-plastic.md)
    # GGX: up to 6.3e-4 in T and 7e-4 relative in r: Mitsuba samples visible GGX normals with
    # another map of the random numbers (its concentric-disk sample_visible_11), so the same
    # Gauss-Legendre nodes fall on other normals; Beckmann: up to 1.7e-3 (2e-3 relative) where
    # Mitsuba's rational approximation of Smith's G1 (its own bound: 0.35 %) departs from the exact
    # one, 1e-6 elsewhere.
    ours = our_coat_tables(queue, {"alpha": alpha, "distribution": distribution, "ior": ior,
                                   "exterior_ior": exterior_ior})
    assert ours.shape == (1, SIZE + 1)
    t, r = mitsuba_coat_tables(alpha, distribution, ior, exterior_ior)
    tolerance = 1e-3 if distribution == "ggx" else 2.5e-3
    np.testing.assert_allclose(ours[0, :SIZE], t, atol=tolerance)
    assert ours[0, SIZE] == pytest.approx(r, rel=tolerance)


@pytest.mark.parametrize("low,high", [(0.05, 0.5), (0.001, 1.0)])
def test_textured_alpha_tables_interpolate_within_mitsubas_own_accuracy(queue, low, high):
    # A textured alpha (Mitsuba's roughplastic takes none) gets rows evenly spaced in sqrt(alpha)
    # over the texture's values, at most COAT_SQRT_ALPHA_STEP apart, interpolated linearly.
    # Against the exact table at alphas midway between rows (GGX: fast to tabulate), the error in
    # T stays below that of Mitsuba's own linear interpolation in mu at the range's low end
    # (docs/materials-plastic.md: 2.0e-3 at alpha 0.05, 1.2e-2 at 0.001); its cosine-weighted
    # mean (what a diffuse lobe sees) below 4e-4, the differences between two valid quadratures
    # of Mitsuba's tables (test above: GGX 6e-4 at most). The internal reflectance's error
    # relative to 1 - r (its effect on the diffuse lobe) below 1e-3, a tenth of the error of
    # Mitsuba's own 64-point rule for r against the integral it stands for (1.3-1.5 % of r).
    image = np.array([[low, high]], np.float32)
    rows = our_coat_tables(queue, {"alpha": {"texture": "a"}},
                           [{"name": "a", "type": "bitmap", "image": image}])
    count = plastic.alpha_rows(np.float32(low), np.float32(high))
    assert rows.shape == (count, SIZE + 1) and count == 1 + np.ceil((np.sqrt(high) - np.sqrt(low)) * 32)
    nodes = np.linspace(np.sqrt(np.float32(low)), np.sqrt(np.float32(high)), count)
    mu = np.linspace(0, 1, SIZE)
    worst_t = worst_weighted = worst_r = 0.0
    for k in range(0, count - 1, 2):
        s = (nodes[k] + nodes[k + 1]) / 2
        (exact,) = our_coat_tables(queue, {"alpha": float(s * s)})
        between = (rows[k] + rows[k + 1]) / 2
        error = np.abs(between[:SIZE] - exact[:SIZE])
        worst_t = max(worst_t, error.max())
        worst_weighted = max(worst_weighted, 2 * np.mean(error * mu))
        worst_r = max(worst_r, abs(between[SIZE] - exact[SIZE]) / (1 - exact[SIZE]))
    assert worst_t < (2.0e-3 if low >= 0.05 else 1.2e-2)
    assert worst_weighted < 4e-4 and worst_r < 1e-3


def test_alpha_textures_span_their_values():
    checks = textures.Texture("c", "checkerboard", color0=np.full(3, 0.3), color1=np.array([0.1, 0.2, 0.4]))
    grey = textures.Texture("g", "bitmap", pixels=np.array([[[0], [255]], [[64], [128]]], np.uint8), srgb=True)
    assert checks.number_range() == pytest.approx((0.1 * 0.212671 + 0.2 * 0.71516 + 0.4 * 0.072169, 0.3))
    assert grey.number_range() == (0.0, 1.0)
    material = clrender.scene.Material("m", "plastic", textures={"alpha": 0})
    # Rows start at Mitsuba's least width, 1e-4; a texture of zeros is a smooth coat.
    assert plastic.alpha_range(material, [grey], 0.0) == (np.float32(1e-4), 1.0)
    zero = textures.Texture("z", "checkerboard", color0=np.zeros(3), color1=np.zeros(3))
    assert plastic.alpha_range(material, [zero], 0.0) == (0.0, 0.0)


# --------------------------------------------------------------------------------------------
# The BSDF against Mitsuba's at chosen directions
# --------------------------------------------------------------------------------------------
MATERIALS = {
    "smooth": {"diffuse": [0.7, 0.2, 0.1]},
    "smooth-nonlinear": {"diffuse": [0.7, 0.2, 0.1], "specular": [0.9, 0.8, 0.5], "nonlinear": True, "ior": 1.9},
    "beckmann": {"alpha": 0.2, "distribution": "beckmann", "diffuse": [0.1, 0.3, 0.8], "specular": [0.9, 0.8, 0.5]},
    "beckmann-rough": {"alpha": 0.7, "distribution": "beckmann", "nonlinear": True},
    "ggx": {"alpha": 0.3, "distribution": "ggx", "nonlinear": True, "diffuse": [0.1, 0.3, 0.8]},
    "ggx-narrow": {"alpha": 0.05, "distribution": "ggx", "ior": 1.5, "exterior_ior": 1.0},
    "ggx-inverted": {"alpha": 0.2, "distribution": "ggx", "ior": 1.0, "exterior_ior": 1.33, "diffuse": 0.9},
}
# Relative tolerances of f * cos and of the density against Mitsuba's. Smooth: float rounding.
# GGX: the coat tables' 1e-3 (above), in T(cos_o) T(cos_i); the density's lobe probability
# (1 - T) w / ... amplifies a table difference by 1 / (1 - T). Beckmann: Mitsuba's approximation
# of G1 (0.35 %) twice in the specular lobe and through the tables twice in the diffuse one.
TOLERANCES = {"smooth": (1e-5, 1e-5), "ggx": (2e-3, 3e-3), "beckmann": (8e-3, 2e-2)}


def tolerance(name):
    return TOLERANCES[name.split("-")[0]]


@pytest.mark.parametrize("name", list(MATERIALS))
def test_eval_and_pdf_are_mitsubas(context, queue, kernels, name):
    material = MATERIALS[name]
    ours, theirs = ours_bsdf(context, queue, kernels, material), their_bsdf(material)
    rng = np.random.default_rng(4)
    f_tolerance, pdf_tolerance = tolerance(name)
    for cos_o in (0.95, 0.5, 0.1):
        wo = direction(cos_o, 0.3)
        wi = hemisphere(300, rng)
        f, pdf = ours.eval(wo, wi)
        si, ctx = interaction(wo), mi.BSDFContext()
        f_m = np.array([np.array(theirs.eval(ctx, si, mi.Vector3f(*w))) for w in wi])
        pdf_m = np.array([theirs.pdf(ctx, si, mi.Vector3f(*w)) for w in wi])
        np.testing.assert_allclose(f, f_m, rtol=f_tolerance, atol=1e-7)
        np.testing.assert_allclose(pdf, pdf_m, rtol=pdf_tolerance, atol=1e-7)
        # Below the surface, from either side: nothing (reflection only).
        f, pdf = ours.eval(wo, wi * [1, 1, -1])
        assert np.all(f == 0) and np.all(pdf == 0)


@pytest.mark.parametrize("name", ["smooth", "smooth-nonlinear"])
def test_smooth_coat_mirror_is_mitsubas(context, queue, kernels, name):
    # The mirror of the smooth coat is picked with Mitsuba's probability and weight: each of our
    # samples' delta flags is the lobe Mitsuba picks with the same first random number.
    material = MATERIALS[name]
    ours, theirs = ours_bsdf(context, queue, kernels, material), their_bsdf(material)
    for cos_o in (1.0, 0.6, 0.2, 0.02):
        wo = direction(cos_o, 1.0)
        wi, pdf, weight, _, delta = ours.sample(wo, 4000, seed=2)
        assert delta.any()
        bs, w = theirs.sample(mi.BSDFContext(), interaction(wo), 0.0, mi.Point2f(0.5, 0.5))
        assert bs.sampled_type & int(mi.BSDFFlags.DeltaReflection)
        np.testing.assert_allclose(pdf[delta], bs.pdf, rtol=1e-5)
        np.testing.assert_allclose(weight[delta], np.broadcast_to(np.array(w), weight[delta].shape), rtol=1e-5)
        np.testing.assert_allclose(wi[delta], np.broadcast_to(wo * [-1, -1, 1], wi[delta].shape), atol=1e-6)
        # The fraction of mirror samples is that probability (binomial, 5 SE).
        p = bs.pdf
        assert abs(delta.mean() - p) < 5 * np.sqrt(p * (1 - p) / delta.size) + 1e-6


# --------------------------------------------------------------------------------------------
# Sampling against density, reciprocity, energy
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name,cos_o", [("smooth", 0.7), ("beckmann", 0.8), ("beckmann-rough", 0.3),
                                        ("ggx", 0.5), ("ggx-narrow", 0.9), ("ggx-inverted", 0.4)])
def test_sampling_follows_its_pdf_and_weights_are_eval_over_pdf(context, queue, kernels, name, cos_o):
    bsdf = ours_bsdf(context, queue, kernels, MATERIALS[name])
    wo = direction(cos_o, 0.3)
    count = 200_000
    wi, pdf, weight, eta, delta = bsdf.sample(wo, count, seed=3)
    assert np.all(eta == 1)
    valid = (pdf > 0) & ~delta
    assert_samples_follow_the_density(bsdf, wo, wi, pdf, weight, valid)


@pytest.mark.parametrize("name", list(MATERIALS))
def test_plastic_is_reciprocal(context, queue, kernels, name):
    # Both lobes are symmetric in wo and wi: the diffuse one through T(cos_o) T(cos_i), the
    # glossy one through F(wo.h) D(h) G1(wo) G1(wi) (the same h, and wo.h = wi.h).
    bsdf = ours_bsdf(context, queue, kernels, MATERIALS[name])
    rng = np.random.default_rng(6)
    a, b = hemisphere(500, rng), hemisphere(500, rng)
    f_ab = np.concatenate([bsdf.eval(x, y[None])[0] for x, y in zip(a, b)]) / b[:, 2:]
    f_ba = np.concatenate([bsdf.eval(y, x[None])[0] for x, y in zip(a, b)]) / a[:, 2:]
    np.testing.assert_allclose(f_ab, f_ba, rtol=2e-5, atol=1e-8)


def mitsuba_albedo(bsdf, wo, count, rng):
    """Mitsuba's directional albedo at wo: its own sample weights (eval / pdf, its delta lobe's
    weight / probability), mean and standard error."""
    si, ctx = interaction(wo), mi.BSDFContext()
    weights = np.array([np.array(bsdf.sample(ctx, si, float(u1), mi.Point2f(*u2))[1])[0]
                        for u1, u2 in zip(rng.uniform(size=count), rng.uniform(size=(count, 2)))])
    return weights.mean(), weights.std() / np.sqrt(count)


@pytest.mark.parametrize("material", [{}, {"alpha": 0.1, "distribution": "beckmann"},
                                      {"alpha": 0.5, "distribution": "ggx"},
                                      {"alpha": 0.3, "distribution": "ggx", "nonlinear": True, "ior": 1.9}],
                         ids=["smooth", "beckmann", "ggx", "ggx-nonlinear"])
def test_white_plastic_albedo_is_mitsubas(context, queue, kernels, material):
    # Diffuse 1 and specular 1: Mitsuba's model keeps energy only approximately. Our mean sample
    # weight (the directional albedo) is Mitsuba's, both estimated by Monte Carlo: within 5
    # combined standard errors plus 0.5 % (the Beckmann G1 approximation and table differences
    # above). The smooth coat keeps it within 0.5 % of 1 (Mitsuba's fit of the diffuse Fresnel
    # reflectance); a rough coat loses what its single-scattering tables do not count (light
    # masked by the relief): the albedo stays below 1 (docs/materials-plastic.md: 0.97 at alpha
    # 0.1, 0.54 at GGX alpha 0.5).
    material = dict(material, diffuse=1.0, specular=1.0)
    ours, theirs = ours_bsdf(context, queue, kernels, material), their_bsdf(material)
    rng = np.random.default_rng(7)
    for cos_o in (1.0, 0.7, 0.3, 0.08):
        wo = direction(cos_o, 0.2)
        _, pdf, weight, _, _ = ours.sample(wo, 100_000, seed=9)
        w = np.where(pdf > 0, weight[:, 0], 0.0)
        mean, error = w.mean(), w.std() / np.sqrt(w.size)
        their_mean, their_error = mitsuba_albedo(theirs, wo, 20_000, rng)
        assert abs(mean - their_mean) < 5 * np.hypot(error, their_error) + 5e-3 * their_mean, (cos_o, mean, their_mean)
        if "alpha" in material:
            assert mean < 1 - 5 * error, (cos_o, mean)
        else:
            assert abs(mean - 1) < 5e-3, (cos_o, mean)
