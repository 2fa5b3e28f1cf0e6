"""Texture coordinates of the built-in shapes, as Mitsuba 3 defines them: the rectangle's and
the cube's exactly, the disk's as close as a triangle fan allows, the analytic sphere's from its
object frame (which transforms carry), compared with Mitsuba's intersections where installed."""
import numpy as np
import pytest

from clrender import meshes

try:
    import mitsuba as mi
except ImportError:
    mi = None
needs_mitsuba = pytest.mark.skipif(mi is None, reason="Mitsuba 3 is not installed (pip install -e '.[peers]')")


def interpolated_uv(mesh, points):
    """The uv a hit at each point (N, 2) of a flat mesh in the plane z = 0 interpolates: the
    barycentric mix of its triangle's corner uvs."""
    corners = mesh.vertices[mesh.faces][:, :, :2]
    found = []
    for point in points:
        edge1, edge2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
        offset = point - corners[:, 0]
        det = edge1[:, 0] * edge2[:, 1] - edge1[:, 1] * edge2[:, 0]
        b1 = (offset[:, 0] * edge2[:, 1] - offset[:, 1] * edge2[:, 0]) / det
        b2 = (edge1[:, 0] * offset[:, 1] - edge1[:, 1] * offset[:, 0]) / det
        inside = np.flatnonzero((b1 >= -1e-12) & (b2 >= -1e-12) & (b1 + b2 <= 1 + 1e-12))
        face = mesh.faces[inside[0]]
        weights = np.array([1 - b1[inside[0]] - b2[inside[0]], b1[inside[0]], b2[inside[0]]])
        found.append(weights @ mesh.uvs[face])
    return np.array(found)


def mitsuba_uv(plugin, points, **parameters):
    """Mitsuba's si.uv where rays straight down -z hit `plugin` at (x, y) points."""
    mi.set_variant("scalar_rgb")
    shape = mi.load_dict({"type": plugin, **parameters})
    found = []
    for x, y in points:
        hit = shape.ray_intersect(mi.Ray3f([x, y, 5.0], [0.0, 0.0, -1.0]))
        assert hit.is_valid()
        found.append(np.array(hit.uv))
    return np.array(found)


@needs_mitsuba
def test_rectangle_uvs_are_mitsubas():
    points = np.random.default_rng(1).uniform(-1, 1, (64, 2))
    np.testing.assert_allclose(interpolated_uv(meshes.rectangle(), points), mitsuba_uv("rectangle", points), atol=1e-6)


def test_rectangle_corners_map_to_the_unit_square():
    rectangle = meshes.rectangle()
    np.testing.assert_array_equal(rectangle.uvs, (rectangle.vertices[:, :2] + 1) / 2)


@needs_mitsuba
def test_cube_is_mitsubas_vertex_for_vertex():
    mi.set_variant("scalar_rgb")
    theirs = mi.traverse(mi.load_dict({"type": "cube"}))
    ours = meshes.box()
    np.testing.assert_array_equal(ours.vertices, np.array(theirs["vertex_positions"]).reshape(-1, 3))
    np.testing.assert_array_equal(ours.faces, np.array(theirs["faces"]).reshape(-1, 3))
    np.testing.assert_array_equal(ours.uvs, np.array(theirs["vertex_texcoords"]).reshape(-1, 2))
    # Mitsuba's per-face vertex normals are its flat normals: the winding faces the same way.
    corners = ours.vertices[ours.faces]
    flat = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    np.testing.assert_allclose(flat / np.linalg.norm(flat, axis=1, keepdims=True),
                               np.array(theirs["vertex_normals"]).reshape(-1, 3)[ours.faces[:, 0]])


SEGMENTS = 64


def disk_points(count, seed=2):
    """Points inside both Mitsuba's unit disk and the fan's polygon (whose chords dip to
    R cos(pi / n) < 1), all around."""
    rng = np.random.default_rng(seed)
    radius = np.sqrt(rng.uniform(0, 0.99 ** 2, count))
    angle = rng.uniform(0, 2 * np.pi, count)
    return np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)


def angle_gap(a, b):
    """|a - b| for v = phi / 2 pi, across the seam at 0 = 1."""
    gap = np.abs(a - b) % 1
    return np.minimum(gap, 1 - gap)


@needs_mitsuba
def test_disk_uvs_are_mitsubas_within_the_fans_bounds():
    """u = r is at most 1 / cos(pi / n) too large (the chord's dip), v = phi / 2 pi off by at
    most half a triangle's angle (the centre vertex's v): the bounds disk() states."""
    points = disk_points(500)
    ours, theirs = interpolated_uv(meshes.disk(SEGMENTS), points), mitsuba_uv("disk", points)
    ratio = ours[:, 0] / theirs[:, 0]
    assert np.all(ratio >= 1 - 1e-6) and np.all(ratio <= 1 / np.cos(np.pi / SEGMENTS) + 1e-6)
    assert np.all(angle_gap(ours[:, 1], theirs[:, 1]) <= 0.5 / SEGMENTS + 1e-6)


@needs_mitsuba
def test_disk_uvs_are_exact_along_the_middle_of_each_triangle():
    radius = np.linspace(0.05, 0.95, 7)
    angle = 2 * np.pi * (np.arange(SEGMENTS) + 0.5) / SEGMENTS
    r, a = np.meshgrid(radius, angle)
    # The chord's middle is R cos(pi / n) from the centre: u there is R, r is that times cos.
    points = np.stack([(r * np.cos(a)).ravel(), (r * np.sin(a)).ravel()], axis=1)
    ours, theirs = interpolated_uv(meshes.disk(SEGMENTS), points), mitsuba_uv("disk", points)
    np.testing.assert_allclose(ours[:, 1], theirs[:, 1], atol=1e-6)
    np.testing.assert_allclose(ours[:, 0] * np.cos(np.pi / SEGMENTS), theirs[:, 0], rtol=1e-6)


def test_disk_never_interpolates_across_its_seam():
    disk = meshes.disk(SEGMENTS)
    v = disk.uvs[disk.faces][:, :, 1]
    assert np.all(v.max(axis=1) - v.min(axis=1) <= 1 / SEGMENTS + 1e-12)
    assert v.max() == 1 and v.min() == 0


TRANSFORMS = [
    meshes.transform_matrix(),
    meshes.transform_matrix(translate=[1, 2, 3], rotate=[30, 40, 50], scale=2.5),
    meshes.transform_matrix(translate=[-4, 0, 1], rotate=[0, 70, -20], scale=[0.5, -0.5, 0.5]),   # a mirror
    meshes.transform_matrix(rotate=[90, 0, 0], scale=[-1, -1, -1]),                                 # inversion
]


@needs_mitsuba
@pytest.mark.parametrize("matrix", TRANSFORMS, ids=["identity", "rotated", "mirrored", "inverted"])
def test_sphere_uvs_are_mitsubas_under_transforms(matrix):
    """Rays hit Mitsuba's sphere (centre, radius and to_world as given); sphere_uv of our
    transformed Sphere at those points gives Mitsuba's si.uv."""
    mi.set_variant("scalar_rgb")
    center, radius = np.array([0.5, -0.2, 0.1]), 0.7
    theirs = mi.load_dict({"type": "sphere", "center": center.tolist(), "radius": radius,
                           "to_world": mi.ScalarTransform4f(matrix.tolist())})
    ours = meshes.apply_transform(meshes.Sphere(center, radius), matrix)
    rng = np.random.default_rng(4)
    hits, uvs = [], []
    while len(hits) < 200:
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        origin = ours.center - 4 * ours.radius * direction + rng.normal(size=3) * ours.radius * 0.6
        hit = theirs.ray_intersect(mi.Ray3f(origin.tolist(), direction.tolist()))
        if hit.is_valid():
            hits.append(np.array(hit.p))
            uvs.append(np.array(hit.uv))
    found = meshes.sphere_uv(ours, np.array(hits))
    uvs = np.array(uvs)
    assert np.all(angle_gap(found[:, 0], uvs[:, 0]) < 2e-5)   # u wraps at phi = 0
    np.testing.assert_allclose(found[:, 1], uvs[:, 1], atol=2e-5)


def test_sphere_rotation_composes_and_survives_flips():
    sphere = meshes.Sphere(np.zeros(3), 1.0)
    first, second = TRANSFORMS[1], TRANSFORMS[2]
    twice = meshes.apply_transform(meshes.apply_transform(sphere, first), second)
    once = meshes.apply_transform(sphere, second @ first)
    np.testing.assert_allclose(twice.rotation, once.rotation, atol=1e-12)
    np.testing.assert_allclose(twice.rotation @ twice.rotation.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(twice.rotation) < 0   # the mirror is kept: Mitsuba's uv mirrors too
    flipped = meshes.flip(twice)
    assert flipped.flipped and flipped.rotation is twice.rotation


def test_sphere_uv_of_its_poles_and_axes():
    sphere = meshes.apply_transform(meshes.Sphere(np.array([1.0, 2, 3]), 2.0), meshes.transform_matrix(rotate=[90, 0, 0]))
    # Rotated 90 degrees about x: the object's +z (v = 0) points along world -y, its +y along +z.
    points = sphere.center + 2.0 * np.array([[0, -1, 0], [0, 1, 0], [1, 0, 0], [0, 0, 1], [-1, 0, 0]])
    np.testing.assert_allclose(meshes.sphere_uv(sphere, points)[:, 1], [0, 1, 0.5, 0.5, 0.5], atol=1e-12)
    np.testing.assert_allclose(meshes.sphere_uv(sphere, points[2:])[:, 0], [0, 0.25, 0.5], atol=1e-12)


def test_transforms_and_flips_keep_mesh_uvs():
    box = meshes.box()
    moved = meshes.flip(meshes.apply_transform(box, TRANSFORMS[2]))
    assert moved.uvs is box.uvs
    np.testing.assert_array_equal(moved.faces, box.faces)   # mirrored, then flipped: the winding is back
