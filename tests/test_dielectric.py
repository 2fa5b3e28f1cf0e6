"""Dielectric and conductor materials, and the robustness of rays spawned from surfaces.

Kernel-level checks call the BSDF dispatch that the integrator uses (kernels/tests.cl) at a
surface point whose normals are +z. Statistical checks use fixed seeds and require
|estimate - expected| < 5 standard errors (conftest.z_bound), which fails by chance about once in
1.7 million; chi-square checks require chi2 < dof + 5 sqrt(2 dof).
"""
import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender import layout, meshes
from clrender.arrays import build_scene_arrays
from clrender.energy import fill_albedo_tables
from conftest import build_test_kernels, camera, sphere, z_bound

mf = cl.mem_flags


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def kernels(context):
    return build_test_kernels(context, DIELECTRIC=1)


def upload(context, array):
    return cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(array))


def run(queue, kernel, size, *args, outputs):
    """Run `kernel` over `size` items; `outputs` are float32 arrays (shapes) to read back."""
    context = queue.context
    out = [np.empty(shape, np.float32) for shape in outputs]
    buffers = [cl.Buffer(context, mf.WRITE_ONLY, x.nbytes) for x in out]
    kernel(queue, (size,), None, *args, *buffers)
    for array, buffer in zip(out, buffers):
        cl.enqueue_copy(queue, array, buffer)
    return out


def float4(vectors):
    vectors = np.atleast_2d(np.asarray(vectors, dtype=float))
    out = np.zeros((len(vectors), 4), np.float32)
    out[:, :3] = vectors
    return out


def direction(cos_theta, phi=0.0):
    s = np.sqrt(max(0.0, 1.0 - cos_theta ** 2))
    return np.array([s * np.cos(phi), s * np.sin(phi), cos_theta])


class Bsdf:
    """One material record (with its energy tables) evaluated through bsdf.h on the device."""

    def __init__(self, context, queue, program, material):
        scene = clrender.load_scene_dict({
            "camera": camera(), "materials": [dict(material, name="m")],
            "shapes": [{"type": "rectangle", "material": "m"}]})
        arrays = build_scene_arrays(scene)
        fill_albedo_tables(queue, arrays)
        self.queue, self.program = queue, program
        self.record = arrays.materials[:1].copy()
        self.tables = arrays.specular_albedo
        self.buffers = (upload(context, self.record), upload(context, self.tables))
        self.sample_kernel = cl.Kernel(program, "sample_bsdf_values")
        self.eval_kernel = cl.Kernel(program, "eval_bsdf_values")

    def sample(self, wo, count, front_face=True, seed=1, ns=(0, 0, 1)):
        """Arrays wi (count, 3), pdf_w, weight (count, 3), eta, delta."""
        wo = np.broadcast_to(np.asarray(wo, dtype=float), (count, 3))
        wi, weight = run(self.queue, self.sample_kernel, count, *self.buffers, np.int32(front_face),
                         float4(ns)[0], upload(self.queue.context, float4(wo)), np.uint32(seed),
                         outputs=[(count, 4), (count, 4)])
        return wi[:, :3], wi[:, 3], weight[:, :3], np.abs(weight[:, 3]), weight[:, 3] < 0

    def eval(self, wo, wi, front_face=True, ns=(0, 0, 1)):
        """f * |cos| (n, 3) and pdf_w (n,) for pairs (wo, wi)."""
        wi = np.atleast_2d(wi)
        wo = np.broadcast_to(np.asarray(wo, dtype=float), wi.shape)
        context = self.queue.context
        (out,) = run(self.queue, self.eval_kernel, len(wi), *self.buffers, np.int32(front_face),
                     float4(ns)[0], upload(context, float4(wo)), upload(context, float4(wi)),
                     outputs=[(len(wi), 4)])
        return out[:, :3], out[:, 3]


def fresnel_reference(cos_i, eta):
    """Unpolarised reflectance from the angles (Born and Wolf): a different formula from the
    kernel's, in float64. Returns (R, T) with T from the transmission amplitudes."""
    cos_i = np.asarray(cos_i, dtype=float)
    sin_i = np.sqrt(1 - cos_i ** 2)
    sin_t = sin_i / eta
    tir = sin_t >= 1
    cos_t = np.sqrt(np.clip(1 - sin_t ** 2, 0, 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        ti, tt = np.arcsin(sin_i), np.arcsin(np.clip(sin_t, 0, 1))
        rs = np.where(ti + tt > 0, np.sin(ti - tt) ** 2 / np.sin(ti + tt) ** 2, ((eta - 1) / (eta + 1)) ** 2)
        rp = np.where(ti + tt > 0, np.tan(ti - tt) ** 2 / np.tan(ti + tt) ** 2, ((eta - 1) / (eta + 1)) ** 2)
        ts = 2 * cos_i / (cos_i + eta * cos_t)
        tp = 2 * cos_i / (eta * cos_i + cos_t)
        t = eta * cos_t / cos_i * (ts ** 2 + tp ** 2) / 2
    return np.where(tir, 1.0, (rs + rp) / 2), np.where(tir, 0.0, t)


def uniform_sphere(count, rng):
    z = rng.uniform(-1, 1, count)
    phi = rng.uniform(0, 2 * np.pi, count)
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


# --------------------------------------------------------------------------------------------
# Scene files: fields, defaults, validation
# --------------------------------------------------------------------------------------------
def scene_with(material):
    return {"camera": camera(), "materials": [dict(material, name="m")],
            "shapes": [{"type": "sphere", "material": "m"}]}


def test_dielectric_and_conductor_fields_reach_the_material_records():
    scene = clrender.load_scene_dict({
        "camera": camera(),
        "materials": [{"name": "glass", "type": "dielectric"},
                      {"name": "water", "type": "dielectric", "ior": 1.33, "exterior_ior": 1.5,
                       "tint": [0.9, 1.0, 0.8], "roughness": 0.4},
                      {"name": "gold", "type": "conductor", "tint": [1.0, 0.8, 0.3], "roughness": 0.5},
                      {"name": "mirror", "type": "conductor"}],
        "shapes": [{"type": "sphere", "material": name}
                   for name in ("glass", "water", "gold", "mirror")]})
    glass, water, gold, mirror = scene.materials
    assert (glass.ior, glass.exterior_ior, glass.roughness) == (1.5, 1.0, 0.0)
    assert np.array_equal(glass.tint, [1, 1, 1]) and np.array_equal(mirror.tint, [1, 1, 1])
    records = build_scene_arrays(scene).materials
    field = lambda name: layout.field(records, layout.MATERIAL_FIELDS, name)  # noqa: E731
    kinds = layout.MATERIAL_KINDS
    assert field("kind").tolist() == [kinds["dielectric"], kinds["dielectric"], kinds["conductor"], kinds["conductor"]]
    np.testing.assert_allclose([field(name)[1] for name in ("ior", "exterior_ior", "alpha")], [1.33, 1.5, 0.4 ** 2],
                               rtol=1e-7)
    np.testing.assert_allclose(field("color")[2], [1.0, 0.8, 0.3])
    # Rough lobes own energy tables (two sides for a dielectric); smooth ones none.
    size = layout.ALBEDO_TABLE_SIZE
    assert field("albedo_tables").tolist() == [-1, 0, 2 * size, -1]


def test_unused_rough_glass_needs_neither_the_feature_nor_tables(device):
    scene = clrender.load_scene_dict({
        "camera": camera(resolution=(8, 8)),
        "materials": [{"name": "white", "type": "diffuse"},
                      {"name": "frosted", "type": "dielectric", "roughness": 0.5}],
        "shapes": [{"type": "sphere", "material": "white"}],
        "lights": [{"type": "environment", "radiance": 1.0}]})
    renderer = clrender.Renderer(scene, device)
    assert renderer.features["DIELECTRIC"] == 0 and renderer.arrays.table_materials == []
    assert renderer.render(spp=2).discarded_samples == 0


@pytest.mark.parametrize("field,value,message", [
    ("ior", 0, "materials[0].ior: must be > 0"),
    ("ior", -1.5, "materials[0].ior: must be > 0"),
    ("exterior_ior", 0.0, "materials[0].exterior_ior: must be > 0"),
    ("roughness", 1.5, "materials[0].roughness: must be <= 1"),
    ("roughness", -0.1, "materials[0].roughness: must be >= 0"),
    ("tint", [1.2, 1, 1], "materials[0].tint: must be <= 1 per channel"),
    ("tint", [0.5, -1, 1], "materials[0].tint: must be non-negative"),
    ("albedo", [0.5, 0.5, 0.5], "materials[0].albedo: unknown field"),
])
def test_invalid_dielectric_fields_are_reported_with_their_place(field, value, message):
    with pytest.raises(clrender.SceneError) as error:
        clrender.load_scene_dict(scene_with({"type": "dielectric", field: value}))
    assert str(error.value).startswith(message), str(error.value)


def test_conductor_has_no_index_of_refraction():
    with pytest.raises(clrender.SceneError, match=r"^materials\[0\]\.ior: unknown field"):
        clrender.load_scene_dict(scene_with({"type": "conductor", "ior": 1.5}))


# --------------------------------------------------------------------------------------------
# Fresnel, Snell, total internal reflection
# --------------------------------------------------------------------------------------------
ETAS = [1.5, 1 / 1.5, 1.1, 4.0, 0.75, 1.0 / 1.33]


def fresnel_and_refraction(queue, kernels, cos_i, eta):
    cos_eta = np.zeros((len(cos_i), 2), np.float32)
    cos_eta[:, 0], cos_eta[:, 1] = cos_i, eta
    (out,) = run(queue, cl.Kernel(kernels, "fresnel_refract_values"), len(cos_i),
                 upload(queue.context, cos_eta),
                 outputs=[(len(cos_i), 4)])
    return out[:, 0].astype(float), out[:, 1:].astype(float)


@pytest.mark.parametrize("eta", ETAS)
def test_fresnel_identities(queue, kernels, eta):
    cos_i = np.concatenate([[1.0, 0.0, 1e-7], np.linspace(1e-3, 1, 997)])
    r, _ = fresnel_and_refraction(queue, kernels, cos_i, eta)
    # Normal incidence: ((n1 - n2) / (n1 + n2))^2 with n2 / n1 = eta.
    assert r[0] == pytest.approx(((1 - eta) / (1 + eta)) ** 2, rel=1e-6)
    reference_r, reference_t = fresnel_reference(cos_i, eta)
    # Against the angle form in float64, and energy: R + T = 1 with T from the transmission
    # amplitudes. float32 evaluation: 1e-5 absolute.
    ok = cos_i > 1e-6
    np.testing.assert_allclose(r[ok], reference_r[ok], atol=1e-5)
    np.testing.assert_allclose(r[ok] + reference_t[ok], 1.0, atol=1e-5)
    assert np.all(np.isfinite(r)) and np.all((r >= 0) & (r <= 1))
    assert r[1] == 1.0 and r[2] > 0.9999  # grazing incidence reflects everything
    if eta < 1:
        critical = np.sqrt(1 - eta ** 2)
        beyond = cos_i < critical * (1 - 1e-6)
        assert np.all(r[beyond] == 1.0)  # total internal reflection: exactly 1


def test_index_matched_interface_reflects_nothing(queue, kernels):
    cos_i = np.linspace(1e-3, 1, 1000)
    r, wt = fresnel_and_refraction(queue, kernels, cos_i, 1.0)
    assert np.all(r == 0.0)
    wo = np.stack([np.sqrt(1 - cos_i ** 2), np.zeros_like(cos_i), cos_i], axis=1)
    np.testing.assert_allclose(wt, -wo, atol=1e-6)  # straight on


@pytest.mark.parametrize("eta", ETAS)
def test_refracted_directions_obey_snell(queue, kernels, eta):
    cos_i = np.concatenate([[1.0], np.linspace(1e-4, 1, 2000)])
    _, wt = fresnel_and_refraction(queue, kernels, cos_i, eta)
    sin_i = np.sqrt(1 - cos_i ** 2)
    refracted = np.any(wt != 0, axis=1)
    # No refraction ray exactly where Snell's law has no solution (up to float32 rounding).
    assert np.all(refracted[sin_i / eta < 1 - 1e-5]) and not np.any(refracted[sin_i / eta > 1 + 1e-5])
    wt, sin_i = wt[refracted], sin_i[refracted]
    np.testing.assert_allclose(np.linalg.norm(wt, axis=1), 1.0, atol=1e-6)
    assert np.all(wt[:, 2] < 0)      # through the interface
    assert np.all(wt[:, 1] == 0)     # in the plane of incidence
    assert np.all(wt[:, 0] <= 0)     # on the far side of the normal
    sin_t = np.hypot(wt[:, 0], wt[:, 1])
    np.testing.assert_allclose(eta * sin_t, sin_i, atol=3e-6)  # n1 sin(theta1) = n2 sin(theta2)


@pytest.mark.parametrize("ior,ns", [(1.5, (0, 0, 1)), (4.0, (0, 0, 1)), (1.5, (0.3, 0.0, 1.0))])
def test_total_internal_reflection_never_leaves_through_the_face(context, queue, kernels, ior, ns):
    # A ray inside a slab (wo on the inner side: not front-facing) beyond the critical angle:
    # every sample reflects, whatever the random numbers, with weight exactly 1 and no eta.
    # With an interpolated normal tilted away from the facet, angles beyond both critical angles:
    # the facet decides, and its refraction does not exist.
    bsdf = Bsdf(context, queue, kernels, {"type": "dielectric", "ior": ior})
    critical = np.sqrt(1 - 1 / ior ** 2)
    flat = ns == (0, 0, 1)
    for c in np.linspace(1e-6, critical * 0.999 if flat else 0.35, 25):
        for phi in (0.0, 2.0, np.pi):
            wo = direction(c, phi)
            wi, pdf, weight, eta, delta = bsdf.sample(wo, 256, front_face=False, ns=ns)
            assert np.all(delta) and np.all(pdf > 0)
            assert np.all(wi[:, 2] > 0), (c, phi)  # never through the face
            np.testing.assert_array_equal(weight, 1.0)
            np.testing.assert_array_equal(eta, 1.0)
            if flat:  # the mirror image of wo
                np.testing.assert_allclose(wi, np.broadcast_to(wo * [-1, -1, 1], wi.shape), atol=1e-6)


@pytest.mark.parametrize("ior,exterior", [(1.5, 1.0), (4.0, 1.0), (1.0, 1.33)])
@pytest.mark.parametrize("front_face", [True, False])
def test_smooth_dielectric_picks_reflection_with_fresnel_probability(context, queue, kernels, ior,
                                                                     exterior, front_face):
    tint = np.array([0.9, 0.6, 0.3])
    bsdf = Bsdf(context, queue, kernels, {"type": "dielectric", "ior": ior, "exterior_ior": exterior,
                                          "tint": tint.tolist()})
    eta = ior / exterior if front_face else exterior / ior
    count = 20000
    for c in (1.0, 0.7, 0.3, 0.05):
        wo = direction(c, 0.4)
        wi, pdf, weight, eta_out, delta = bsdf.sample(wo, count, front_face=front_face, seed=7)
        assert np.all(delta)
        reflected = wi[:, 2] > 0
        f = float(fresnel_reference(c, eta)[0])
        # Binomial count of reflections within 5 standard errors.
        assert abs(reflected.mean() - f) <= 5 * np.sqrt(f * (1 - f) / count) + 1e-6, (c, f)
        np.testing.assert_allclose(pdf[reflected], f, atol=1e-5)
        np.testing.assert_array_equal(weight[reflected], 1.0)
        if f < 1:
            np.testing.assert_allclose(pdf[~reflected], 1 - f, atol=1e-5)
            # Radiance transport: the tint and 1 / eta^2 on refraction (dielectric.h).
            np.testing.assert_allclose(weight[~reflected], np.broadcast_to(tint / eta ** 2, (np.sum(~reflected), 3)),
                                       rtol=1e-5)
            np.testing.assert_allclose(eta_out[~reflected], eta, rtol=1e-6)


# --------------------------------------------------------------------------------------------
# Rough lobes: sampling against density, density against value, energy
# --------------------------------------------------------------------------------------------
Z_BINS, PHI_BINS, SUB = 24, 48, 6


def sphere_bins_quadrature(sub=SUB):
    """Midpoints of sub x sub cells inside each (z, phi) bin of equal solid angle."""
    z = -1 + 2 * (np.arange(Z_BINS * sub) + 0.5) / (Z_BINS * sub)
    phi = 2 * np.pi * (np.arange(PHI_BINS * sub) + 0.5) / (PHI_BINS * sub)
    zz, pp = np.meshgrid(z, phi, indexing="ij")
    r = np.sqrt(1 - zz ** 2)
    dirs = np.stack([r * np.cos(pp), r * np.sin(pp), zz], axis=-1).reshape(-1, 3)
    cell_solid_angle = 4 * np.pi / (Z_BINS * sub * PHI_BINS * sub)
    return dirs, cell_solid_angle


def per_bin(values, sub=SUB):
    return values.reshape(Z_BINS, sub, PHI_BINS, sub).sum(axis=(1, 3))


def bin_of(wi):
    zi = np.clip(((wi[:, 2] + 1) / 2 * Z_BINS).astype(int), 0, Z_BINS - 1)
    phi = np.mod(np.arctan2(wi[:, 1], wi[:, 0]), 2 * np.pi)
    pi = np.clip((phi / (2 * np.pi) * PHI_BINS).astype(int), 0, PHI_BINS - 1)
    return zi * PHI_BINS + pi


def assert_samples_follow_the_density(bsdf, wo, wi, pdf, weight, valid, front_face=True, sub=SUB):
    """Samples wi (pdf, weight) of `bsdf` at wo, `valid` those with a density (not delta): their
    histogram against sample_bsdf_pdf integrated per bin (chi-square); the density integrates to
    the fraction of valid samples (some are rejected under the macro surface; binomial standard
    error, plus 0.2% for the quadrature); each weight is f * |cos| / pdf of its direction (the
    same functions NEE and MIS use). Returns f * |cos| at the quadrature's directions (`sub` x
    `sub` per bin) and their cell's solid angle."""
    count = len(wi)
    dirs, cell = sphere_bins_quadrature(sub)
    f_quad, pdf_quad = bsdf.eval(wo, dirs, front_face=front_face)
    p_bin = per_bin(pdf_quad * cell, sub).ravel()
    observed = np.bincount(bin_of(wi[valid]), minlength=p_bin.size)
    expected = p_bin * count
    big = expected > 20
    chi2 = np.sum((observed[big] - expected[big]) ** 2 / expected[big])
    dof = big.sum() - 1
    assert chi2 < dof + 5 * np.sqrt(2 * dof), (chi2, dof)
    fraction = valid.mean()
    assert abs(p_bin.sum() - fraction) < 5 * np.sqrt(fraction * (1 - fraction) / count) + 2e-3
    f_s, pdf_s = bsdf.eval(wo, wi[valid][:2000], front_face=front_face)
    np.testing.assert_allclose(pdf_s, pdf[valid][:2000], rtol=2e-4)
    np.testing.assert_allclose(weight[valid][:2000], f_s / pdf_s[:, None], rtol=2e-4)
    return f_quad, cell


def check_sampling(bsdf, wo, front_face, seed, count=200_000, sub=SUB):
    """The sampler of `bsdf` at wo against its pdf (assert_samples_follow_the_density, `sub` x
    `sub` quadrature points per bin), and the mean weight against the quadrature of the value.
    Returns wi, pdf, eta of the samples and whether each was produced."""
    wi, pdf, weight, eta, delta = bsdf.sample(wo, count, front_face=front_face, seed=seed)
    assert not np.any(delta)
    valid = pdf > 0
    f_quad, cell = assert_samples_follow_the_density(bsdf, wo, wi, pdf, weight, valid, front_face, sub)
    # And so the integral of f * |cos| (quadrature) equals the mean weight (Monte Carlo): 5 SE
    # of the Monte Carlo mean, plus 0.5% for the quadrature of the value.
    for channel in range(3):
        w = np.where(valid, weight[:, channel], 0.0)
        integral = np.sum(f_quad[:, channel]) * cell
        assert abs(integral - w.mean()) < 5 * w.std() / np.sqrt(count) + 5e-3 * integral
    return wi, pdf, eta, valid


ROUGH_CASES = [
    ({"type": "dielectric", "ior": 1.5, "roughness": 0.5}, True, 0.8),
    ({"type": "dielectric", "ior": 1.5, "roughness": 0.5}, False, 0.9),   # inside: microfacet TIR
    ({"type": "dielectric", "ior": 1.5, "roughness": 0.8}, False, 0.3),
    ({"type": "dielectric", "ior": 0.75, "roughness": 0.6}, True, 0.5),   # an ior < 1 interface
    ({"type": "conductor", "tint": [0.9, 0.5, 0.2], "roughness": 0.5}, True, 0.4),
    # Mitsuba's model: Beckmann, separable masking-shadowing
    ({"type": "dielectric", "ior": 1.5, "roughness": 0.5, "distribution": "beckmann", "masking": "separable"},
     True, 0.7),
    ({"type": "dielectric", "ior": 1.5, "roughness": 0.7, "distribution": "beckmann", "masking": "separable"},
     False, 0.6),
    ({"type": "conductor", "tint": [0.9, 0.5, 0.2], "roughness": 0.6, "distribution": "beckmann"}, True, 0.3),
    ({"type": "conductor", "roughness": 0.5, "masking": "separable"}, True, 0.5),
    # complex Fresnel, tinted reflection
    ({"type": "conductor", "material": "Au", "roughness": 0.4, "distribution": "beckmann", "masking": "separable",
      "energy_compensation": False}, True, 0.6),
    ({"type": "dielectric", "ior": 1.5, "roughness": 0.5, "reflection_tint": [0.3, 0.6, 0.9]}, True, 0.4),
]


@pytest.mark.parametrize("material,front_face,cos_o", ROUGH_CASES,
                         ids=["glass-out", "glass-in", "glass-in-rough", "bubble", "conductor", "beckmann-glass-out",
                              "beckmann-glass-in", "beckmann-conductor", "separable-conductor", "gold",
                              "tinted-reflection"])
def test_rough_sampling_follows_its_pdf_and_weights_are_eval_over_pdf(context, queue, kernels, material,
                                                                       front_face, cos_o):
    check_sampling(Bsdf(context, queue, kernels, material), direction(cos_o, 0.3), front_face, seed=3)


@pytest.mark.parametrize("material", [
    {"type": "dielectric", "ior": 1.5, "roughness": 0.3},
    {"type": "dielectric", "ior": 1.5, "roughness": 1.0},
    {"type": "dielectric", "ior": 4.0, "roughness": 0.6},
    {"type": "conductor", "roughness": 0.3},
    {"type": "conductor", "roughness": 1.0},
    {"type": "dielectric", "ior": 1.5, "roughness": 0.8, "distribution": "beckmann", "masking": "separable"},
    {"type": "conductor", "roughness": 0.8, "distribution": "beckmann"},
], ids=["glass-0.3", "glass-1.0", "ior4-0.6", "mirror-0.3", "mirror-1.0", "beckmann-glass", "beckmann-mirror"])
def test_energy_compensation_makes_lossless_rough_lobes_white(context, queue, kernels, material):
    # Without compensation a GGX mirror of roughness 1 keeps 31% at normal incidence; with it a
    # lossless lobe keeps all the energy for every wo: the mean weight (without tint and the
    # radiance 1/eta^2) is 1 within 5 SE, plus 0.3% for the table (its 192^2-point quadrature
    # and interpolation; measured errors are below 0.2%).
    bsdf = Bsdf(context, queue, kernels, material)
    count = 100_000
    sides = (True, False) if material["type"] == "dielectric" else (True,)
    for front_face in sides:
        for cos_o in (1.0, 0.8, 0.5, 0.2, 0.05):
            wi, pdf, weight, eta, _ = bsdf.sample(direction(cos_o, 1.0), count, front_face=front_face, seed=5)
            energy = np.where(pdf > 0, weight[:, 0] * eta ** 2, 0.0)
            assert np.all(np.isfinite(energy))
            tolerance = 5 * energy.std() / np.sqrt(count) + 3e-3
            assert abs(energy.mean() - 1) < tolerance, (front_face, cos_o, energy.mean(), tolerance)


@pytest.mark.parametrize("material", [
    {"type": "dielectric", "ior": 1.5}, {"type": "dielectric", "ior": 4.0, "roughness": 0.2},
    {"type": "dielectric", "ior": 0.75, "roughness": 0.7}, {"type": "dielectric", "ior": 1.5, "roughness": 0.01},
    {"type": "conductor"}, {"type": "conductor", "roughness": 0.05},
], ids=["glass", "ior4-rough", "bubble-rough", "nearly-smooth", "mirror", "rough-mirror"])
def test_grazing_and_degenerate_directions_stay_finite(context, queue, kernels, material):
    # cos(wo) down to 0 exactly, wi grazing or opposite to wo, normals tilted away from the facet:
    # every value, density and weight is finite and non-negative.
    bsdf = Bsdf(context, queue, kernels, material)
    rng = np.random.default_rng(2)
    cosines = [0.0, 1e-9, 1e-6, 1e-3, 0.5, 1.0]
    for ns in [(0, 0, 1), (0.5, 0, 1), (-0.8, 0.3, 0.2)]:
        for front_face in (True, False):
            for c in cosines:
                wo = direction(c, 0.3)
                wi, pdf, weight, eta, _ = bsdf.sample(wo, 2000, front_face=front_face, ns=ns)
                for x in (wi, pdf, weight, eta):
                    assert np.all(np.isfinite(x))
                assert np.all(pdf >= 0) and np.all(weight >= 0)
                others = np.concatenate([uniform_sphere(200, rng), [-wo, wo, [0, 0, 1], [0, 0, -1]],
                                         [direction(g, 2.0) for g in cosines],
                                         [-direction(g, 2.0) for g in cosines]])
                f, p = bsdf.eval(wo, others, front_face=front_face, ns=ns)
                assert np.all(np.isfinite(f)) and np.all(np.isfinite(p))
                assert np.all(f >= 0) and np.all(p >= 0)


# --------------------------------------------------------------------------------------------
# Renders with known answers
# --------------------------------------------------------------------------------------------
def per_sample_images(renderer, count, **kwargs):
    """`count` independent 1-spp images (seeds 100..): per-pixel samples for per-pixel tests."""
    return np.stack([renderer.render(spp=1, seed=100 + s, **kwargs).image for s in range(count)])


# The geometries of a unit sphere that furnace tests run on.
SPHERES = {"sphere": {}, "facets": {"mesh": True, "subdivisions": 3, "smooth": False},
           "smooth-normals": {"mesh": True, "subdivisions": 3, "smooth": True}}


def furnace_scene(material, geometry="sphere", resolution=(24, 24)):
    return clrender.load_scene_dict({
        "camera": camera(resolution=resolution, fov=28),
        "materials": [dict(material, name="m")],
        "shapes": [{"type": "sphere", "material": "m", "radius": 1.0, **SPHERES[geometry]}],
        "lights": [{"type": "environment", "radiance": 1.0}],
    })


# Deep enough that no path is cut: a faceted sphere traps some rays in long cycles of total
# internal reflection (at ior 1.5 0.4% of the paths are longer than 64 vertices; at ior 4 a few
# in 10^4 are longer than 1024). Beyond the scene files' limit, so passed to render().
DEEP = 8192


@pytest.mark.parametrize("geometry", list(SPHERES))
@pytest.mark.parametrize("ior", [1.5, 4.0, 0.75])
def test_smooth_glass_sphere_vanishes_in_a_furnace_exactly(device, geometry, ior):
    # Every lobe weight of a smooth lossless dielectric is 1 (or 1/eta^2, undone on the way
    # out), so every sample of every pixel is exactly the environment, up to float rounding.
    scene = furnace_scene({"type": "dielectric", "ior": ior}, geometry)
    spp = 16
    result = clrender.Renderer(scene, device).render(spp=spp, seed=1, max_depth=DEEP, rr_depth=DEEP)
    assert result.discarded_samples == 0
    if geometry != "smooth-normals":
        np.testing.assert_allclose(result.image, 1.0, atol=1e-5)
        return
    # Interpolated normals on a faceted sphere trap a few paths in total internal reflection
    # for good (a known defect: 7-16 of 184,320 samples over seeds 1-20 at depth 64 and at 8192
    # alike, so cycles without end): those samples are 0, every other one exactly the
    # environment. At most 1 in 1000 may be lost (20 times the rate seen).
    lost = (1.0 - result.image) * spp
    np.testing.assert_allclose(lost, np.rint(lost), atol=1e-3)
    assert np.rint(lost).sum() <= result.image[..., 0].size * spp / 1000


@pytest.mark.parametrize("material", [
    {"type": "dielectric", "ior": 1.5, "roughness": 0.3},
    {"type": "dielectric", "ior": 1.5, "roughness": 1.0},
    {"type": "conductor", "roughness": 0.6},
], ids=["glass-0.3", "glass-1.0", "mirror-0.6"])
def test_rough_lossless_sphere_vanishes_in_a_furnace(device, material):
    # Next-event estimation of the environment and BSDF sampling, combined by MIS, through rough
    # lobes made energy conserving (materials/energy.h). Every pixel within 5 SE of 1 (48
    # independent samples per pixel), and the mean over the sphere within 5 SE of 1. With
    # roulette, which must not be fooled by the 1/eta^2 inside the glass.
    renderer = clrender.Renderer(furnace_scene(material), device)
    coverage = renderer.render(spp=1, seed=100, max_depth=1).image[..., 0] < 1
    samples = per_sample_images(renderer, 48, max_depth=DEEP, rr_depth=3)[..., 0]
    assert np.all(np.isfinite(samples))
    z = [z_bound(samples[:, y, x], 1.0) for y, x in zip(*np.nonzero(coverage))]
    assert coverage.sum() > 150 and max(z) < 5.0, max(z)
    assert z_bound(samples[:, coverage], 1.0) < 5.0


@pytest.mark.parametrize("analytic", [True, False], ids=["spheres", "icospheres"])
@pytest.mark.parametrize("roughness", [0.0, 0.4])
def test_glass_sphere_inside_an_emitting_enclosure_sees_its_radiance(device, roughness, analytic):
    # A closed emitter (black, radiance E) around a lossless glass sphere: the radiance field is
    # uniform, E everywhere, whatever the sphere does. Light reaches the camera through area-light
    # sampling combined with BSDF sampling by MIS (rough), or through BSDF sampling alone with full
    # weight after delta lobes (smooth: no next-event estimation through them).
    emission = 0.5
    scene = clrender.load_scene_dict({
        "camera": camera(position=(0, 0, 1.6), look_at=(0, 0, 0), fov=50, resolution=(20, 20)),
        "materials": [{"name": "wall", "type": "emissive", "radiance": emission},
                      {"name": "glass", "type": "dielectric", "ior": 1.5, "roughness": roughness}],
        "shapes": [sphere(analytic, subdivisions=2, material="wall", radius=2.0, flip_normals=True),
                   sphere(analytic, material="glass", radius=0.8)],
    })
    # Smooth: no roulette, so that every sample is exactly E; rough: roulette from depth 3.
    result = clrender.Renderer(scene, device).render(spp=48, seed=2, max_depth=DEEP,
                                                     rr_depth=DEEP if roughness == 0.0 else 3)
    assert result.discarded_samples == 0
    if roughness == 0.0:
        np.testing.assert_allclose(result.image, emission, rtol=1e-5)
    else:
        assert z_bound(result.image, emission) < 5.0


@pytest.mark.parametrize("ior", [1.5, 4.0])
def test_glass_slab_transmits_the_incoherent_sum_of_its_reflections(device, ior):
    # A flat slab at normal incidence in front of an emitter, nothing else: the transmitted
    # fraction summed over all internal reflections is (1 - R)^2 / (1 - R^2) = (1 - R) / (1 + R),
    # R = ((n - 1) / (n + 1))^2; the eta^2 of entering and leaving cancel.
    radiance = 3.0
    scene = clrender.load_scene_dict({
        "camera": camera(position=(0, 0, 4), look_at=(0, 0, 0), fov=4, resolution=(12, 12)),
        "materials": [{"name": "glass", "type": "dielectric", "ior": ior},
                      {"name": "lamp", "type": "emissive", "radiance": radiance}],
        "shapes": [{"type": "box", "material": "glass", "transform": {"scale": [1, 1, 0.05]}},
                   {"type": "rectangle", "material": "lamp",
                    "transform": {"scale": [2, 2, 1], "translate": [0, 0, -1]}}],
    })
    result = clrender.Renderer(scene, device).render(spp=128, seed=4, max_depth=DEEP, rr_depth=DEEP)
    assert result.discarded_samples == 0
    r = ((ior - 1) / (ior + 1)) ** 2
    assert z_bound(result.image, radiance * (1 - r) / (1 + r)) < 5.0


def test_mirror_shows_the_emitter_with_its_tint(device):
    # Emission seen after a delta lobe counts fully: a smooth mirror facing an emitter shows
    # tint * radiance exactly (no next-event estimation at the mirror, no MIS weight after it).
    tint = [0.9, 0.5, 0.25]
    scene = clrender.load_scene_dict({
        "camera": camera(position=(0, 0, 4), look_at=(0, 0, 0), fov=4, resolution=(8, 8)),
        "materials": [{"name": "mirror", "type": "conductor", "tint": tint},
                      {"name": "lamp", "type": "emissive", "radiance": 2.0}],
        "shapes": [{"type": "rectangle", "material": "mirror", "transform": {"rotate": [0, 0, 0]}},
                   # an emitter facing the mirror, behind the camera, in view only through it
                   {"type": "rectangle", "material": "lamp",
                    "transform": {"scale": [3, 3, 1], "rotate": [180, 0, 0], "translate": [0, 0, 6]}}],
        "render": {"max_depth": 4},
    })
    result = clrender.Renderer(scene, device).render(spp=4, seed=1)
    np.testing.assert_allclose(result.image, np.broadcast_to(2.0 * np.array(tint), result.image.shape), rtol=1e-6)


def image_difference_z(image, reference, blocks):
    """Largest |z| of the mean difference of two independent renders of the same expectation,
    over the whole image and over each of blocks x blocks regions, per channel. Differences of
    unbiased pixels all have expectation 0, so their spread estimates the standard error."""
    difference = np.asarray(image, float) - reference
    h, w, _ = difference.shape
    z = [z_bound(difference[..., c], 0.0) for c in range(3)]
    for i in range(blocks):
        for j in range(blocks):
            block = difference[i * h // blocks:(i + 1) * h // blocks, j * w // blocks:(j + 1) * w // blocks]
            z += [z_bound(block[..., c], 0.0) for c in range(3)]
    return max(z)


def small_cornell(path="scenes/cornell_box.json", resolution=(32, 32)):
    scene = clrender.load_scene(path)
    scene.camera.resolution = resolution
    return scene


def cornell_with_large_lamp(sphere_material=None):
    # Light reaching a point through a smooth interface (here an index-matched one) is found by
    # BSDF sampling alone. With the scene's small lamp those rare hits make the pixels in the
    # sphere's shadow heavy-tailed: unbiased (checked at 8192 spp), but 64-spp means fail
    # normal-theory tests. A lamp covering most of the ceiling keeps the test valid and lets it
    # tell ior 1.1 from 1 (asserted below).
    scene = small_cornell(resolution=(48, 48))
    lamp = next(shape for shape in scene.shapes if shape.name == "light")
    centre = lamp.mesh.vertices.mean(axis=0)
    grow = meshes.transform_matrix(translate=centre, scale=[0.9 / 0.235, 1, 0.9 / 0.19]) @ \
        meshes.transform_matrix(translate=-centre)
    lamp.mesh = meshes.apply_transform(lamp.mesh, grow)
    if sphere_material is not None:
        sphere = clrender.load_scene_dict({
            "camera": camera(), "materials": [dict(sphere_material, name="m")],
            "shapes": [{"type": "sphere", "material": "m", "center": [-0.2, 1.0, 0.0], "radius": 0.5}]})
        scene.materials.append(sphere.materials[0])
        scene.shapes.append(clrender.scene.Shape("sphere", len(scene.materials) - 1, sphere.shapes[0].mesh))
    return scene


def test_index_matched_sphere_vanishes_in_the_cornell_box(device):
    # The interface is skipped, rough or not, and whichever index both sides share. Paths through
    # it are two vertices longer, so all renders use a depth that cuts nothing measurable.
    # Independent seeds; 8 x 8 blocks of 6 x 6 pixels, per channel, within 5 SE.
    reference = clrender.Renderer(cornell_with_large_lamp(), device).render(spp=64, seed=1, max_depth=64).image
    for material in ({"type": "dielectric", "ior": 1.0}, {"type": "dielectric", "ior": 1.0, "roughness": 0.5},
                     {"type": "dielectric", "ior": 1.33, "exterior_ior": 1.33, "roughness": 0.2}):
        result = clrender.Renderer(cornell_with_large_lamp(material), device).render(spp=64, seed=2, max_depth=64)
        assert result.discarded_samples == 0
        assert image_difference_z(result.image, reference, blocks=8) < 5.0, material
    # The test can see a sphere that is almost index-matched.
    visible = clrender.Renderer(cornell_with_large_lamp({"type": "dielectric", "ior": 1.1}), device)
    assert image_difference_z(visible.render(spp=64, seed=2, max_depth=64).image, reference, blocks=8) > 5.0


@pytest.mark.parametrize("material", [{"ior": 1.0}, {"ior": 1.33, "exterior_ior": 1.33, "roughness": 0.4},
                                      {"ior": 1.0, "tint": [0.9, 0.6, 0.3]}], ids=["clear", "rough", "tinted"])
def test_index_matched_glass_costs_no_bounce(device, material):
    # A white diffuse wall at z = -1 under a sun shining along -z, seen by a camera at z = 5
    # through an index-matched glass sphere (radius 0.5 at the origin) that also stands between
    # the wall and the sun. At max depth 2 (direct lighting) and roulette from depth 1, every
    # pixel is exactly albedo / pi * irradiance * (tint^2 on the camera ray) * (tint^2 on the
    # shadow ray, inside the sphere's shadow), with no noise: the glass is no path vertex, faces
    # no roulette and does not block shadow rays. (Before, it was two vertices: the wall behind
    # it was beyond max depth, and black.)
    data = {"camera": camera(position=(0, 0, 5), fov=20, resolution=(16, 16)),
            "materials": [{"name": "wall", "type": "diffuse", "albedo": [0.5, 0.5, 0.5]},
                          dict(material, name="glass", type="dielectric")],
            "shapes": [{"type": "rectangle", "material": "wall", "transform": {"scale": 4, "translate": [0, 0, -1]}},
                       {"type": "sphere", "material": "glass", "radius": 0.5}],
            "lights": [{"type": "directional", "direction": [0, 0, -1], "irradiance": 2.0}],
            "render": {"max_depth": 2, "rr_depth": 1}}
    scene = clrender.load_scene_dict(data)
    renderer = clrender.Renderer(scene, device)
    assert renderer.features["DIELECTRIC"] == 0      # rendered as an interface boundary
    result = renderer.render(spp=16, seed=3)
    assert result.discarded_samples == 0
    tint = np.asarray(material.get("tint", 1.0), np.float32) * np.ones(3)
    lit = 0.5 / np.pi * 2.0
    # The central 4 x 4 pixels see the wall through the middle of the sphere, inside its shadow
    # (the wall is 1 unit behind the sphere: perspective shifts the view by < 0.1 there).
    np.testing.assert_allclose(result.image[6:10, 6:10], np.broadcast_to(lit * tint ** 4, (4, 4, 3)), rtol=1e-5)
    # The corners see the wall beside the sphere and its shadow.
    for corner in (result.image[:2, :2], result.image[-2:, -2:]):
        np.testing.assert_allclose(corner, lit, rtol=1e-5)


def moved(scene, scale=1.0, offset=0.0):
    """The same scene scaled about the origin, then translated by (offset, offset, offset)."""
    return scene.transform(meshes.transform_matrix(translate=[offset] * 3, scale=[scale] * 3))


@pytest.mark.parametrize("scale,offset", [(1e-3, 0.0), (1e3, 0.0), (1.0, 1e4), (1e-3, 1.0)],
                         ids=["small", "large", "far", "small-far"])
def test_glass_cornell_box_renders_the_same_at_any_scale_and_place(device, scale, offset):
    # Self-intersection and lost shadow rays show as a darker image or black speckles. Ray
    # offsets are relative to the magnitudes a hit point was computed from (math.h, scene.h).
    # Waechter and Binder's fixed 256-ulp offset, used before, fails the 'far' case (z = 7.7).
    reference = clrender.Renderer(small_cornell("scenes/cornell_glass.json"), device).render(spp=64, seed=1)
    scene = moved(small_cornell("scenes/cornell_glass.json"), scale, offset)
    result = clrender.Renderer(scene, device).render(spp=64, seed=2)
    assert result.discarded_samples == 0
    assert np.all(result.image.sum(axis=2) > 0)  # no black pixel anywhere in the box
    assert image_difference_z(result.image, reference.image, blocks=4) < 5.0


@pytest.mark.parametrize("analytic", [True, False], ids=["sphere", "icosphere"])
@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
@pytest.mark.parametrize("offset", [0.0, 1e4, -3e4])
def test_spawned_rays_never_hit_their_own_surface(context, queue, scale, offset, analytic):
    # Rays hit a closed convex sphere (analytic, or faceted) from outside, then leave the hit
    # point outwards (they must hit nothing: no self-intersection) or inwards (they must hit the
    # sphere again from inside, another facet of a faceted one, beyond their start: no escape
    # through their own surface), at angles down to 1e-4 from grazing.
    program = build_test_kernels(context)
    rng = np.random.default_rng(5)
    centre = np.array([offset, 0.7 * offset, -offset]) * scale
    scene = clrender.load_scene_dict({
        "camera": camera(), "materials": [{"name": "g", "type": "dielectric"}],
        "shapes": [sphere(analytic, material="g", radius=scale, center=centre.tolist())]})
    a = build_scene_arrays(scene)
    count = 40_000
    start = centre + 3 * scale * uniform_sphere(count, rng)
    aim = centre + rng.uniform(-0.7, 0.7, (count, 3)) * scale - start
    cos_n = np.concatenate([10 ** rng.uniform(-4, 0, count // 2), rng.uniform(0, 1, count - count // 2)])
    side = np.where(rng.uniform(size=count) < 0.5, 1.0, -1.0)
    phi = rng.uniform(0, 2 * np.pi, count)
    s = np.sqrt(1 - cos_n ** 2)
    leave = np.stack([s * np.cos(phi), s * np.sin(phi), side * cos_n], axis=1)
    # The kernel sees the scene scaled by a power of two (arrays.device_length_scale): exact.
    (out,) = run(queue, cl.Kernel(program, "spawn_from_hits"), count,
                 *(upload(context, x) for x in (a.nodes, a.blocks, a.spheres, a.shading, a.info, a.uvs)),
                 upload(context, float4(start * a.length_scale)),
                 upload(context, float4(aim / np.linalg.norm(aim, axis=1)[:, None])),
                 upload(context, float4(leave)), outputs=[(count, 4)])
    first, second, t, front = out[:, 0], out[:, 1], out[:, 2], out[:, 3] == 1
    # A first ray can slip between two facets (Moller-Trumbore is not watertight) and hit the
    # far side from inside; such rays (< 1e-4) are not about spawning and are left out.
    hit = (first >= 0) & front
    assert np.mean((first >= 0) & ~front) <= (0 if analytic else 1e-4)
    assert hit.sum() > 0.95 * count
    outward = side > 0
    assert np.all(second[hit & outward] == -1)
    inward = hit & ~outward
    if analytic:  # the chord across, up to the diameter
        assert np.all((second[inward] == first[inward]) & (t[inward] > 0) & (t[inward] <= 2.0001 * scale))
    else:
        assert np.all((second[inward] >= 0) & (second[inward] != first[inward]))


@pytest.mark.parametrize("name", ["cornell_glass", "rough_glass", "tir_prism", "ior_sweep"])
def test_example_scenes_render_finite_images(device, name):
    scene = clrender.load_scene(f"scenes/{name}.json")
    width, height = scene.camera.resolution
    scene.camera.resolution = (24, max(1, round(24 * height / width)))
    result = clrender.Renderer(scene, device).render(spp=8, seed=1)
    assert result.discarded_samples == 0
    assert np.all(np.isfinite(result.image)) and np.all(result.image >= 0)
    assert result.image.mean() > 0.01


@pytest.mark.parametrize("ior,roughness", [(1.5, 0.0), (4.0, 0.0), (0.75, 0.0), (1.5, 0.3), (4.0, 0.7)])
def test_camera_inside_glass_sees_finite_total_internal_reflections(device, ior, roughness):
    # The camera sits inside a glass block whose faces it sees at every angle, grazing included;
    # beyond the critical angle light bounces between the faces (repeated total internal
    # reflection) until it finds a way out or the depth ends. Nothing may be NaN or infinite, and
    # the light outside must come through.
    scene = clrender.load_scene_dict({
        "camera": camera(position=(0.1, 0.05, 0.3), look_at=(1, -0.2, -1), fov=120, resolution=(24, 24)),
        "materials": [{"name": "glass", "type": "dielectric", "ior": ior, "roughness": roughness},
                      {"name": "lamp", "type": "emissive", "radiance": 5.0}],
        "shapes": [{"type": "box", "material": "glass", "transform": {"scale": [2, 0.5, 1]}},
                   {"type": "rectangle", "material": "lamp",
                    "transform": {"rotate": [90, 0, 0], "translate": [0, 2, 0]}}],
        "lights": [{"type": "environment", "radiance": 0.2}],
    })
    result = clrender.Renderer(scene, device).render(spp=8, seed=3, max_depth=64)
    assert result.discarded_samples == 0
    assert np.all(np.isfinite(result.image)) and result.image.mean() > 0
