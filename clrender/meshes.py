"""Shape geometry: triangle meshes (primitives, files loaded with trimesh) and analytic spheres,
and their transforms."""
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass
class Mesh:
    vertices: np.ndarray   # (V, 3) float64, world space
    faces: np.ndarray      # (F, 3) int64
    normals: np.ndarray    # (V, 3) float64 unit shading normals, or None for flat shading
    uvs: np.ndarray = None # (V, 2) float64 texture coordinates (Mitsuba's convention), or None


@dataclass
class Sphere:
    """An analytic sphere (kernels/sphere.h): exact surface and normals."""
    center: np.ndarray     # (3,) float64, world space
    radius: float          # > 0
    flipped: bool = False  # the front face (normals, one-sided emission) is inside
    # Orthonormal object-to-world rotation (a mirror where det < 0): the frame of its uv.
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))


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
        return Sphere(linear @ mesh.center + matrix[:3, 3], mesh.radius * scale, mesh.flipped,
                      linear / scale @ mesh.rotation)
    vertices = mesh.vertices @ linear.T + matrix[:3, 3]
    faces = mesh.faces
    if np.linalg.det(linear) < 0:
        faces = faces[:, ::-1]  # a mirroring transform would turn the winding inside out
    normals = None
    if mesh.normals is not None:
        normals = _normalized(mesh.normals @ np.linalg.inv(linear))
    return Mesh(vertices, faces, normals, mesh.uvs)


def flip(mesh):
    """Reverse the winding (and the shading normals): the other side becomes the front."""
    if isinstance(mesh, Sphere):
        return Sphere(mesh.center, mesh.radius, not mesh.flipped, mesh.rotation)
    return Mesh(mesh.vertices, mesh.faces[:, ::-1].copy(),
                None if mesh.normals is None else -mesh.normals, mesh.uvs)


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


def disk(segments=128):
    """The unit disk in the plane z = 0, facing +z: a fan of `segments` triangles whose polygon
    has the disk's area (pi), so an emitting disk has the exact power."""
    angles = 2 * np.pi * np.arange(segments) / segments
    radius = np.sqrt(2 * np.pi / (segments * np.sin(2 * np.pi / segments)))
    rim = np.stack([radius * np.cos(angles), radius * np.sin(angles), np.zeros(segments)], axis=1)
    vertices = np.concatenate([np.zeros((1, 3)), rim])
    index = np.arange(segments)
    faces = np.stack([np.zeros(segments, int), 1 + index, 1 + (index + 1) % segments], axis=1)
    return Mesh(vertices, faces, None)


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
    """Load OBJ/PLY/glTF/GLB/STL (all meshes of a file merged). Plain OBJ files (vertices and
    triangles only) are read here, as trimesh reads them (importing trimesh takes 0.7 s, longer
    than rendering a small scene); everything else with trimesh.

    Raises ValueError with a message meant for the user when the file holds no triangles, a
    vertex that is not a finite float32 number, or a face naming a vertex that does not exist."""
    if Path(path).suffix.lower() == ".obj":
        mesh = read_plain_obj(path, smooth)
        if mesh is not None:
            return mesh
    import trimesh

    with np.errstate(all="ignore"):   # a malformed file is reported below, not by numpy warnings
        loaded = trimesh.load(str(path), force="mesh", process=False)
    vertices = np.asarray(loaded.vertices, dtype=float)
    faces = np.asarray(loaded.faces, dtype=np.int64)
    if len(faces) == 0:
        raise ValueError("the file holds no triangles")
    if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError(f"expected 3D vertices and triangles, got vertices of shape {vertices.shape} "
                         f"and faces of shape {faces.shape}")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise ValueError(f"a face refers to a vertex that does not exist (the file has {len(vertices)})")
    return _checked_mesh(vertices, faces, smooth)


def _checked_mesh(vertices, faces, smooth):
    """A Mesh of valid triangles (faces name existing vertices), with `smooth` shading normals;
    ValueError for a vertex that is not a finite float32 point."""
    bad = ~np.all(np.isfinite(vertices) & (np.abs(vertices) <= np.finfo(np.float32).max), axis=1)
    if np.any(bad):
        index = int(np.flatnonzero(bad)[0])
        raise ValueError(f"vertex {index + 1} is not a finite float32 point: {vertices[index].tolist()}")
    return Mesh(vertices, faces, vertex_normals(vertices, faces) if smooth else None)


def vertex_normals(vertices, faces):
    """Unit shading normals: at each vertex, the unit normals of the faces around it weighted by
    the face's angle at that vertex (Thuerrner and Wuethrich 1998, as trimesh computes them, but
    without scipy). Faces of zero area, or with an angle below 1e-8, do not contribute."""
    corners = vertices[faces]
    face_normals = _normalized(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]))
    u = _normalized(corners[:, 1] - corners[:, 0])
    v = _normalized(corners[:, 2] - corners[:, 0])
    w = _normalized(corners[:, 2] - corners[:, 1])
    angles = np.empty((len(faces), 3))
    angles[:, 0] = np.arccos(np.clip(np.sum(u * v, axis=1), -1, 1))
    angles[:, 1] = np.arccos(np.clip(np.sum(-u * w, axis=1), -1, 1))
    angles[:, 2] = np.pi - angles[:, 0] - angles[:, 1]
    angles[np.any(angles < 1e-8, axis=1)] = 0.0
    angles[np.sum(face_normals ** 2, axis=1) <= 0.5] = 0.0
    summed = np.stack([sum(np.bincount(faces[:, k], angles[:, k] * face_normals[:, axis], len(vertices))
                           for k in range(3)) for axis in range(3)], axis=1)
    return _normalized(summed)


# The only lines of a plain OBJ file: `v x y z`, `f a b c` (1-based indices), comments, blanks.
_OBJ_VERTEX = re.compile(rb"^v[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)[ \t]*\r?$", re.M)
_OBJ_TRIANGLE = re.compile(rb"^f[ \t]+(\d+)[ \t]+(\d+)[ \t]+(\d+)[ \t]*\r?$", re.M)
_OBJ_STATEMENT = re.compile(rb"^[ \t]*[^#\s]", re.M)


def read_plain_obj(path, smooth):
    """A Mesh from an OBJ file holding only vertex positions and triangles of positive indices,
    or None for any other file (polygons, negative indices, texture coordinates, normals,
    groups, materials, ...: trimesh reads those). The same triangles as trimesh's, and with
    `smooth` its angle-weighted vertex normals."""
    text = Path(path).read_bytes()
    vertices, triangles = _OBJ_VERTEX.findall(text), _OBJ_TRIANGLE.findall(text)
    if not triangles or len(vertices) + len(triangles) != len(_OBJ_STATEMENT.findall(text)):
        return None
    try:
        vertices = np.array(vertices).astype(float)
    except ValueError:   # not numbers: trimesh's error message
        return None
    faces = np.array(triangles).astype(np.int64) - 1
    bad = np.flatnonzero(np.any(faces >= len(vertices), axis=1) | np.any(faces < 0, axis=1))
    if len(bad):
        match = next(m for k, m in enumerate(_OBJ_TRIANGLE.finditer(text)) if k == bad[0])
        line = text.count(b"\n", 0, match.start()) + 1
        raise ValueError(f"line {line}: face {match.group(0).decode().strip()!r} names a vertex "
                         f"beyond the {len(vertices)} of the file")
    return _checked_mesh(vertices, faces, smooth)
