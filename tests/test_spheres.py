"""Analytic spheres: BVH hits against a brute-force reference, the scene format, spherical
emitters sampled by solid angle (closed forms, pdf consistency, chi-square), and the auxiliary
buffers. Furnace, glass, media and scale tests run on analytic spheres in test_furnace.py,
test_dielectric.py and test_media.py.

Tolerances: closed forms within 5 standard errors of the estimator (fixed seeds); chi-square
tests at a 1e-4 significance level (the p-value is deterministic for the fixed seed).
"""
import numpy as np
import pyopencl as cl
import pytest
from scipy import stats

import clrender
from clrender import arrays as scene_arrays
from clrender import layout, meshes, wide_bvh
from clrender.bvh import build_bvh, intersect_brute_force
from clrender.triangle_blocks import triangle_blocks
from clrender.render import render_params
from conftest import build_test_kernels, camera, z_bound

mf = cl.mem_flags


def upload(context, array):
    return cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(array))


def float4(vectors):
    vectors = np.atleast_2d(np.asarray(vectors, dtype=float))
    out = np.zeros((len(vectors), 4), np.float32)
    out[:, :3] = vectors
    return out


# --------------------------------------------------------------------------------------------
# Intersection through the BVH
# --------------------------------------------------------------------------------------------
def trace(context, queue, v0, v1, v2, centres, radii, origins, directions):
    """Closest hits (t, primitive index in the build_bvh numbering, any-hit flag) on the device."""
    tree = build_bvh(v0, v1, v2, spheres=(centres, radii))
    normals = np.zeros((len(v0), 3, 3))
    nodes, _ = wide_bvh.collapse(tree, tree.prim_order >= len(v0))
    order = scene_arrays.spheres_first(nodes, tree.prim_order, len(v0))
    _, spheres = scene_arrays.primitive_slots(order, normals, centres, radii)
    nodes, blocks = triangle_blocks(nodes, v0, v1, v2, order)
    buffers = [upload(context, x) for x in (nodes, blocks, spheres, float4(origins), float4(directions))]
    n = len(origins)
    t, slot, any_hit = np.empty(n, np.float32), np.empty(n, np.int32), np.empty(n, np.int32)
    outputs = [cl.Buffer(context, mf.WRITE_ONLY, x.nbytes) for x in (t, slot, any_hit)]
    cl.Kernel(build_test_kernels(context), "trace_rays")(queue, (n,), None, *buffers, *outputs)
    for host, buffer in zip((t, slot, any_hit), outputs):
        cl.enqueue_copy(queue, host, buffer)
    return t, np.append(order, -1)[slot], any_hit.astype(bool)


@pytest.mark.parametrize("triangles,spheres,seed", [(0, 1, 1), (0, 300, 2), (2000, 300, 3)])
def test_hits_equal_brute_force(context, queue, triangles, spheres, seed):
    rng = np.random.default_rng(seed)
    v0 = rng.uniform(-4, 4, (triangles, 3))
    v1, v2 = v0 + rng.normal(0, 0.6, (triangles, 3)), v0 + rng.normal(0, 0.6, (triangles, 3))
    centres = rng.uniform(-4, 4, (spheres, 3))
    radii = 10 ** rng.uniform(-2, 0, spheres) * np.where(rng.uniform(size=spheres) < 0.2, -1, 1)  # some flipped
    origins = rng.uniform(-8, 8, (6000, 3))
    # Aimed at sphere centres (inside and outside, grazing), and at random points.
    targets = np.where(rng.uniform(size=(6000, 1)) < 0.5, rng.uniform(-3, 3, (6000, 3)),
                       centres[rng.integers(0, spheres, 6000)] + rng.normal(0, 0.5, (6000, 3)))
    directions = (targets - origins) / np.linalg.norm(targets - origins, axis=1, keepdims=True)
    t, prim, any_hit = trace(context, queue, v0, v1, v2, centres, radii, origins, directions)
    ref_t, ref_prim = intersect_brute_force(v0, v1, v2, origins, directions, spheres=(centres, radii))
    hit = ref_prim >= 0
    assert hit.mean() > 0.3
    assert np.array_equal(prim >= 0, hit) and np.array_equal(any_hit, hit)
    # float32 rays: distances are good to 1e-4 relative, and to a few ulp of the origin's
    # coordinates (up to 8) absolute (hits a short way from the origin).
    atol = 16 * np.finfo(np.float32).eps * 8
    np.testing.assert_allclose(t[hit], ref_t[hit], rtol=1e-4, atol=atol)
    differs = prim != ref_prim   # ties within float32 may resolve either way
    assert np.all(np.abs(t[differs] - ref_t[differs]) <= 1e-4 * ref_t[differs] + atol)


@pytest.mark.parametrize("radius,distance", [(1e-3, 1e3), (1e-4, 10.0), (1e3, 1e5)])
def test_small_and_distant_spheres_are_hit_precisely(context, queue, radius, distance):
    # Haines et al.'s discriminant keeps the hits of a sphere tiny against its distance, where
    # b^2 - ac cancels (its rounding, eps d^2, exceeds r^2 here): rays across the disc, up to
    # 0.9 of its radius (the line's distance from the centre is computed to about eps d, a few
    # per cent of the radius at 1e6 radii). The reference takes the float32 directions.
    rng = np.random.default_rng(7)
    count = 4000
    centre = np.array([0.3, -0.2, 0.1]) * distance
    origins = np.zeros((count, 3))
    axis = centre / np.linalg.norm(centre)
    u = np.cross(axis, [0, 0, 1])
    u /= np.linalg.norm(u)
    w = np.cross(axis, u)
    offset = np.sqrt(rng.uniform(0, 1, count))[:, None] * 0.9 * radius
    angle = rng.uniform(0, 2 * np.pi, count)[:, None]
    targets = centre + offset * (np.cos(angle) * u + np.sin(angle) * w)
    directions = (targets / np.linalg.norm(targets, axis=1, keepdims=True)).astype(np.float32)
    t, prim, _ = trace(context, queue, np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)),
                       centre[None], np.array([radius]), origins, directions)
    ref_t, _ = intersect_brute_force(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)), origins, directions,
                                     spheres=(centre[None], np.array([radius])))
    assert np.all(prim == 0)
    # The entry point is found to within a small fraction of the radius.
    assert np.max(np.abs(t - ref_t)) < 1e-2 * radius + 4 * np.finfo(np.float32).eps * distance


def test_leaves_never_mix_triangles_and_spheres():
    rng = np.random.default_rng(3)
    v0 = rng.uniform(-1, 1, (500, 3))
    centres = np.concatenate([v0[:200], rng.uniform(-1, 1, (100, 3))])   # some centres coincide
    tree = build_bvh(v0, v0 + 0.1, v0 + [0.1, 0, 0.1], spheres=(centres, np.full(300, 0.05)))
    nodes, _ = wide_bvh.collapse(tree, tree.prim_order >= 500)
    leaves = nodes["count"] != 0
    for first, count in zip(nodes["child"][leaves], nodes["count"][leaves]):
        kinds = tree.prim_order[first:first + abs(count)] >= 500
        assert np.all(kinds == (count < 0))
    assert sorted(tree.prim_order) == list(range(800))


# --------------------------------------------------------------------------------------------
# Scene format
# --------------------------------------------------------------------------------------------
def one_shape(shape):
    return {"camera": camera(), "materials": [{"name": "m", "type": "diffuse"}],
            "shapes": [dict(material="m", **shape)]}


def test_spheres_are_analytic_unless_tessellation_is_asked_for():
    geometry = clrender.load_scene_dict(one_shape({"type": "sphere", "center": [1, 2, 3], "radius": 2.0,
                                                   "flip_normals": True})).shapes[0].mesh
    assert isinstance(geometry, meshes.Sphere) and geometry.flipped
    assert np.array_equal(geometry.center, [1, 2, 3]) and geometry.radius == 2.0
    mesh = clrender.load_scene_dict(one_shape({"type": "sphere", "mesh": True, "subdivisions": 1})).shapes[0].mesh
    assert isinstance(mesh, meshes.Mesh) and len(mesh.faces) == 80


def test_sphere_transforms_keep_it_a_sphere():
    shape = {"type": "sphere", "center": [1, 0, 0], "radius": 0.5,
             "transform": {"scale": [-2, 2, 2], "rotate": [0, 90, 0], "translate": [0, 1, 0]}}
    geometry = clrender.load_scene_dict(one_shape(shape)).shapes[0].mesh
    np.testing.assert_allclose(geometry.center, [0, 1, 2], atol=1e-12)
    assert geometry.radius == pytest.approx(1.0) and not geometry.flipped  # mirroring keeps it outward
    lo, hi = clrender.load_scene_dict(one_shape(shape)).bounds()
    np.testing.assert_allclose(lo, [-1, 0, 1], atol=1e-12)


@pytest.mark.parametrize("shape,where,message", [
    ({"type": "sphere", "subdivisions": 2}, "shapes[0].subdivisions", "mesh"),
    ({"type": "sphere", "smooth": False}, "shapes[0].smooth", "mesh"),
    ({"type": "sphere", "transform": {"scale": [1, 2, 1]}}, "shapes[0].transform", "ellipsoid"),
    ({"type": "sphere", "mesh": "yes"}, "shapes[0].mesh", "true or false"),
])
def test_sphere_errors_name_their_place(shape, where, message):
    with pytest.raises(clrender.SceneError, match=message) as error:
        clrender.load_scene_dict(one_shape(shape))
    assert error.value.where == where


# --------------------------------------------------------------------------------------------
# Spherical emitters
# --------------------------------------------------------------------------------------------
def sample_sphere_light(context, queue, points, centre, radius, flipped=False, seed=1):
    """One light sample per point of a scene whose only emitter is a sphere of radiance 1:
    (wi and pdf_w (N, 4), q and distance (N, 4), area_emitter_pdf_w at q and cosine (N, 2))."""
    scene = clrender.load_scene_dict({
        "camera": camera(), "materials": [{"name": "lamp", "type": "emissive", "radiance": 1.0}],
        "shapes": [{"type": "sphere", "material": "lamp", "center": list(centre), "radius": radius,
                    "flip_normals": flipped}]})
    a = scene_arrays.build_scene_arrays(scene)
    assert a.emitters["kind"][0, 0] == layout.EMITTER_KINDS["sphere"]
    params = render_params(scene, a, 0, 1, 8, 5, 0)
    n = len(points)
    out = [np.empty((n, 4), np.float32), np.empty((n, 4), np.float32), np.empty((n, 2), np.float32)]
    buffers = [cl.Buffer(context, mf.WRITE_ONLY, x.nbytes) for x in out]
    kernel = cl.Kernel(build_test_kernels(context), "sample_area_emitter")
    kernel(queue, (n,), None, upload(context, a.emitters), upload(context, a.emitter_cdf), upload(context, params),
           upload(context, float4(points)), np.uint32(seed), *buffers)
    for host, buffer in zip(out, buffers):
        cl.enqueue_copy(queue, host, buffer)
    return out


@pytest.mark.parametrize("radius,distance", [(1.0, 3.0), (1.0, 1.05), (0.01, 3.0)],
                         ids=["cone", "wide-cone", "small-cone"])
def test_sphere_light_seen_from_outside(context, queue, radius, distance):
    # From a point at distance d from the centre of a sphere of radiance 1, the sphere fills a
    # cone of sin^2 theta_max = (r / d)^2 (below 1.5 degrees the sampler's small-angle branch).
    # Closed form: the irradiance on a plane facing the centre is pi (r / d)^2.
    count = 200_000
    centre = np.array([0.2, -0.1, 0.4])
    axis = np.array([0.6, 0.0, 0.8])
    points = np.tile(centre - distance * axis, (count, 1))
    (sample, q, pdf), sin2_max = sample_sphere_light(context, queue, points, centre, radius), (radius / distance) ** 2
    wi, pdf_w = sample[:, :3].astype(float), sample[:, 3].astype(float)
    one_minus_cos_max = 1 - np.sqrt(1 - sin2_max)
    np.testing.assert_allclose(pdf_w, 1 / (2 * np.pi * one_minus_cos_max), rtol=1e-4)
    np.testing.assert_allclose(pdf[:, 0], pdf_w, rtol=1e-5)   # the same pdf when a BSDF ray hits q
    # q lies on the sphere, on the side that faces the point, along wi.
    np.testing.assert_allclose(np.linalg.norm(q[:, :3] - centre, axis=1), radius, rtol=1e-4)
    assert np.all(pdf[:, 1] > -1e-3)
    # Unit directions up to float32 rounding (GPUs divide to 2.5 ulp). The tests of their angles
    # take them normalised: in a 0.2 degree cone, a norm 1e-7 off shifts 1 - cos theta by 2 % of
    # its range (the KS test on the raw vectors: p = 1e-5 on NVIDIA's GPU, 0.02 on PoCL; on the
    # normalised ones 0.75 on PoCL, and it passes on NVIDIA's).
    np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1.0, atol=1e-6)
    wi /= np.linalg.norm(wi, axis=1)[:, None]
    cos_theta = wi @ axis
    irradiance = cos_theta / pdf_w
    # Within 5 SE, or float32 rounding where the cone is so narrow that the estimate barely varies.
    standard_error = irradiance.std(ddof=1) / np.sqrt(count)
    assert abs(irradiance.mean() - np.pi * sin2_max) < 5 * standard_error + 1e-5 * np.pi * sin2_max
    # Uniform inside the cone: 1 - cos theta uniform on [0, 1 - cos theta_max], phi uniform.
    assert stats.kstest((1 - cos_theta) / one_minus_cos_max, "uniform").pvalue > 1e-4
    u = np.cross(axis, [0, 1, 0])
    phi = np.arctan2(wi @ np.cross(axis, u), wi @ u)
    assert stats.chisquare(np.histogram(phi, 32, (-np.pi, np.pi))[0]).pvalue > 1e-4


@pytest.mark.parametrize("flipped", [False, True])
def test_flipped_sphere_light_from_inside_and_back_faces(context, queue, flipped):
    # Inside a sphere emitting inwards (radiance 1), the irradiance on any plane is pi, whatever
    # its place and orientation; it is sampled by area. From where only back faces are seen
    # (inside an outward emitter, outside an inward one) the pdf is 0.
    rng = np.random.default_rng(2)
    count = 100_000
    centre, radius = np.array([1.0, 2.0, 3.0]), 2.0
    inside = centre + rng.uniform(-0.8, 0.8, (count, 3))
    (sample, q, pdf) = sample_sphere_light(context, queue, inside, centre, radius, flipped=flipped)
    if not flipped:
        assert np.all(sample[:, 3] == 0)
        outside = centre + np.array([0, 0, 2.5])
        assert np.all(sample_sphere_light(context, queue, outside[None], centre, radius, flipped=True)[0][:, 3] == 0)
        return
    wi, pdf_w = sample[:, :3].astype(float), sample[:, 3].astype(float)
    assert np.all(pdf_w > 0)
    np.testing.assert_allclose(pdf[:, 0], pdf_w, rtol=1e-4)
    np.testing.assert_allclose(np.linalg.norm(q[:, :3] - centre, axis=1), radius, rtol=1e-4)
    normal = rng.normal(size=(count, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    irradiance = np.clip(np.sum(wi * normal, axis=1), 0, None) / pdf_w
    assert z_bound(irradiance, np.pi) < 5.0


def test_plane_lit_by_a_sphere_light_matches_the_closed_form(device):
    # A diffuse floor under a spherical lamp, direct light only (max depth 2): next-event
    # estimation and BSDF samples that hit the lamp, weighted by MIS, must sum to
    # albedo / pi x E, with E = pi L (r / d)^2 cos(angle to the centre) for a sphere wholly above
    # the floor's horizon. Expected per pixel: over an 8 x 8 grid of sub-pixel rays.
    albedo, radiance, centre, radius = 0.7, 3.0, np.array([0.3, 0.9, -0.2]), 0.4
    scene = clrender.load_scene_dict({
        "camera": camera(position=(0, 2.5, 2.5), look_at=(0, 0, 0), fov=30, resolution=(24, 24)),
        "materials": [{"name": "floor", "type": "diffuse", "albedo": [albedo] * 3},
                      {"name": "lamp", "type": "emissive", "radiance": radiance}],
        "shapes": [{"type": "rectangle", "material": "floor", "transform": {"rotate": [-90, 0, 0], "scale": 3}},
                   {"type": "sphere", "material": "lamp", "center": centre.tolist(), "radius": radius}],
        "render": {"max_depth": 2}})
    result = clrender.Renderer(scene, device).render(spp=256, seed=9)
    assert result.discarded_samples == 0
    width, height = scene.camera.resolution
    offsets = (np.arange(8) + 0.5) / 8
    jx, jy = np.meshgrid(offsets, offsets)
    px, py = np.meshgrid(np.arange(width), np.arange(height))
    d = scene.camera.pixel_directions(px[..., None] + jx.ravel(), py[..., None] + jy.ravel())
    t = -scene.camera.position[1] / d[..., 1]
    points = scene.camera.position + t[..., None] * d
    to_centre = centre - points
    dist = np.linalg.norm(to_centre, axis=-1)
    irradiance = np.pi * radiance * (radius / dist) ** 2 * to_centre[..., 1] / dist
    expected = (albedo / np.pi * irradiance).mean(axis=-1)
    floor = (result.aux["object_id"] == 0)
    floor &= np.all(np.abs(points[..., [0, 2]]) < 2.9, axis=(-1, -2))   # on the floor for every sub-pixel ray
    sees_lamp = np.linalg.norm(np.cross(d, (centre - scene.camera.position)), axis=-1) < radius * 1.01
    floor &= ~np.any(sees_lamp, axis=-1)
    assert floor.sum() > 300
    assert z_bound(result.image[floor][:, 0] - expected[floor], 0.0) < 5.0


def test_aux_buffers_see_the_exact_silhouette(device):
    # The pixel-centre rays that hit an analytic sphere are exactly those whose distance to its
    # centre is below the radius (up to float rounding at the rim); the normal is the radial one.
    centre, radius = np.array([0.2, -0.1, 0.0]), 0.8
    scene = clrender.load_scene_dict({
        "camera": camera(resolution=(40, 40)), "materials": [{"name": "m", "type": "diffuse"}],
        "shapes": [{"type": "sphere", "material": "m", "center": centre.tolist(), "radius": radius}],
        "lights": [{"type": "environment", "radiance": 1.0}]})
    aux = clrender.Renderer(scene, device).render(spp=1).aux
    px, py = np.meshgrid(np.arange(40) + 0.5, np.arange(40) + 0.5)
    d = scene.camera.pixel_directions(px, py)
    o = scene.camera.position
    along = (centre - o) @ d.reshape(-1, 3).T
    miss = np.linalg.norm(o + along.reshape(40, 40, 1) * d - centre, axis=-1) - radius
    clear = np.abs(miss) > 1e-4
    assert np.array_equal((aux["object_id"] == 0)[clear], (miss < 0)[clear])
    hit = (aux["object_id"] == 0) & clear
    p = o + (aux["depth"][hit] / (d[hit] @ (scene.camera.look_at - o) / np.linalg.norm(scene.camera.look_at - o)))[:, None] * d[hit]
    np.testing.assert_allclose(aux["normal"][hit], (p - centre) / radius, atol=1e-4)
