"""Triangle meshes: primitives, files loaded with trimesh, and transforms."""
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass
class Mesh:
    vertices: np.ndarray   # (V, 3) float64, world space
    faces: np.ndarray      # (F, 3) int64
    normals: np.ndarray    # (V, 3) float64 unit shading normals, or None for flat shading


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
    """Transform positions by `matrix` and normals by its inverse transpose."""
    linear = matrix[:3, :3]
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
    return Mesh(mesh.vertices, mesh.faces[:, ::-1].copy(),
                None if mesh.normals is None else -mesh.normals)


def _normalized(v):
    length = np.linalg.norm(v, axis=1, keepdims=True)
    return v / np.where(length > 0, length, 1.0)


def sphere(center=(0, 0, 0), radius=1.0, subdivisions=4, smooth=True):
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
    """Load OBJ/PLY/glTF/GLB/STL (all meshes of a file merged) with trimesh.

    Raises ValueError with a message meant for the user when the file holds no triangles, a
    vertex that is not a finite float32 number, or a face naming a vertex that does not exist."""
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
    bad = ~np.all(np.isfinite(vertices) & (np.abs(vertices) <= np.finfo(np.float32).max), axis=1)
    if np.any(bad):
        index = int(np.flatnonzero(bad)[0])
        raise ValueError(f"vertex {index + 1} is not a finite float32 point: {vertices[index].tolist()}")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise ValueError(f"a face refers to a vertex that does not exist (the file has {len(vertices)})")
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
