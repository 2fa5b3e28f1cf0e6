"""Shape geometry: triangle meshes (primitives, files loaded with trimesh) and analytic spheres,
and their transforms."""
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass
class Mesh:
    vertices: np.ndarray   # (V, 3) float64, world space
    faces: np.ndarray      # (F, 3) int64
    normals: np.ndarray    # (V, 3) float64 unit shading normals, or None for flat shading


@dataclass
class Sphere:
    """An analytic sphere (kernels/sphere.h): exact surface and normals."""
    center: np.ndarray     # (3,) float64, world space
    radius: float          # > 0
    flipped: bool = False  # the front face (normals, one-sided emission) is inside


def bounds(geometry):
    """(min, max) corners of a Mesh's vertices or a Sphere."""
    if isinstance(geometry, Sphere):
        return geometry.center - geometry.radius, geometry.center + geometry.radius
    return geometry.vertices.min(axis=0), geometry.vertices.max(axis=0)


def similarity_scale(linear, tolerance=1e-9):
    """The uniform scale s of a 3x3 matrix that is s times a rotation (or a reflection), or None
    when it scales unevenly or shears (it would turn a sphere into an ellipsoid)."""
    gram = linear.T @ linear
    scale2 = np.trace(gram) / 3
    if not scale2 > 0 or np.abs(gram - scale2 * np.eye(3)).max() > tolerance * scale2:
        return None
    return float(np.sqrt(scale2))


def transform_matrix(translate=(0, 0, 0), rotate=(0, 0, 0), scale=(1, 1, 1)):
    """4x4 matrix applying scale, then rotations about x, y, z (degrees), then translation."""
    sx, sy, sz = np.broadcast_to(np.asarray(scale, dtype=float), (3,))
    m = np.diag([sx, sy, sz, 1.0])
    for axis, degrees in enumerate(rotate):
        if degrees:
            m = _rotation(axis, np.radians(degrees)) @ m
    m[:3, 3] += np.asarray(translate, dtype=float)
    return m


def _rotation(axis, angle):
    c, s = np.cos(angle), np.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(4)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def apply_transform(mesh, matrix):
    """Transform positions by `matrix` and normals by its inverse transpose. A Sphere takes only
    similarity transforms (ValueError otherwise); a reflection keeps its front face outside, as
    it keeps a mesh's (the winding is reversed with it)."""
    linear = matrix[:3, :3]
    if isinstance(mesh, Sphere):
        scale = similarity_scale(linear)
        if scale is None:
            raise ValueError("scales a sphere unevenly (that makes an ellipsoid): add \"mesh\": true "
                             "to tessellate it")
        return Sphere(linear @ mesh.center + matrix[:3, 3], mesh.radius * scale, mesh.flipped)
    vertices = mesh.vertices @ linear.T + matrix[:3, 3]
    faces = mesh.faces
    if np.linalg.det(linear) < 0:
        faces = faces[:, ::-1]  # a mirroring transform would turn the winding inside out
    normals = None
    if mesh.normals is not None:
        normals = _normalized(mesh.normals @ np.linalg.inv(linear))
    return Mesh(vertices, faces, normals)


def flip(mesh):
    """Reverse the winding (and the shading normals): the other side becomes the front."""
    if isinstance(mesh, Sphere):
        return Sphere(mesh.center, mesh.radius, not mesh.flipped)
    return Mesh(mesh.vertices, mesh.faces[:, ::-1].copy(),
                None if mesh.normals is None else -mesh.normals)


def _normalized(v):
    length = np.linalg.norm(v, axis=1, keepdims=True)
    return v / np.where(length > 0, length, 1.0)


def icosphere(center=(0, 0, 0), radius=1.0, subdivisions=4, smooth=True):
    """Icosphere; smooth: shading normals are the exact sphere normals, else flat facets."""
    import trimesh

    unit = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    v = _normalized(np.asarray(unit.vertices, dtype=float))
    return Mesh(v * radius + np.asarray(center, dtype=float), np.asarray(unit.faces), v if smooth else None)


def rectangle():
    """The square [-1, 1]^2 in the plane z = 0, facing +z."""
    v = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=float)
    return Mesh(v, np.array([[0, 1, 2], [0, 2, 3]]), None)


def box():
    """The cube [-1, 1]^3 with outward-facing flat faces."""
    faces = []
    vertices = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            u, w = (axis + 1) % 3, (axis + 2) % 3
            corners = []
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = np.zeros(3)
                p[axis], p[u], p[w] = sign, a, b
                corners.append(p)
            base = len(vertices)
            vertices += corners
            quad = [[base, base + 1, base + 2], [base, base + 2, base + 3]]
            faces += quad if sign > 0 else [f[::-1] for f in quad]
    return Mesh(np.array(vertices), np.array(faces), None)


def load_mesh_file(path: Path, smooth: bool):
    """Load OBJ/PLY/glTF/GLB/STL (all meshes of a file merged). OBJ files of vertices and faces
    are read here (importing trimesh takes 0.7 s, longer than rendering a small scene); other
    formats, and OBJ files with normals of their own when `smooth`, with trimesh."""
    if Path(path).suffix.lower() == ".obj":
        mesh = read_obj(path, smooth)
        if mesh is not None:
            return mesh
    import trimesh

    loaded = trimesh.load(str(path), force="mesh", process=False)
    vertices = np.asarray(loaded.vertices, dtype=float)
    faces = np.asarray(loaded.faces, dtype=np.int64)
    if len(faces) == 0:
        raise ValueError("the file holds no triangles")
    normals = None
    if smooth:
        normals = _normalized(np.asarray(loaded.vertex_normals, dtype=float))
    return Mesh(vertices, faces, normals)


def read_obj(path, smooth):
    """A Mesh from the `v` and `f` lines of an OBJ file (polygons as triangle fans; indices
    1-based or negative, relative to the vertices read so far; `v/vt/vn` takes the position). Other
    lines (texture coordinates, groups, materials, lines, points) are not geometry we render.
    Returns None for a file with normals of its own when `smooth` (trimesh reads those).
    smooth: angle-weighted vertex normals, as trimesh computes them."""
    vertices, faces = [], []
    with open(path) as f:
        for number, line in enumerate(f, start=1):
            kind, _, rest = line.strip().partition(" ")
            if kind == "v":
                vertices.append([float(x) for x in rest.split()[:3]])
            elif kind == "f":
                corners = [int(token.split("/")[0]) for token in rest.split()]
                corners = [c - 1 if c > 0 else len(vertices) + c for c in corners]
                if not all(0 <= c < len(vertices) for c in corners) or len(corners) < 3:
                    raise ValueError(f"line {number}: invalid face {rest.strip()!r}")
                faces += [[corners[0], corners[k], corners[k + 1]] for k in range(1, len(corners) - 1)]
            elif kind == "vn" and smooth:
                return None
    if not faces:
        raise ValueError("the file holds no triangles")
    vertices, faces = np.asarray(vertices, dtype=float).reshape(-1, 3), np.asarray(faces, dtype=np.int64)
    return Mesh(vertices, faces, angle_weighted_normals(vertices, faces) if smooth else None)


def angle_weighted_normals(vertices, faces):
    """Unit vertex normals: the faces' normals around each vertex weighted by the face's angle
    there (trimesh's weighted_vertex_normals)."""
    corners = vertices[faces]
    normals = _normalized(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]))
    sums = np.zeros_like(vertices)
    for k in range(3):
        a = _normalized(corners[:, (k + 1) % 3] - corners[:, k])
        b = _normalized(corners[:, (k + 2) % 3] - corners[:, k])
        angle = np.arccos(np.clip(np.sum(a * b, axis=1), -1.0, 1.0))
        np.add.at(sums, faces[:, k], normals * angle[:, None])
    return _normalized(sums)
