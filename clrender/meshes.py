"""Shape geometry: triangle meshes (primitives, mesh files) and analytic spheres, their
transforms and texture coordinates.

Texture coordinates follow Mitsuba 3: uv (0, 0) is the top-left corner of an image, u to the
right, v down (a file's v is flipped, v -> 1 - v, where Mitsuba's `flip_tex_coords` says so).
Primitives carry Mitsuba's uv mapping of the same shape (see each)."""
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import limits
from .files import check_regular_file


@dataclass
class Mesh:
    vertices: np.ndarray   # (V, 3) float64, world space
    faces: np.ndarray      # (F, 3) int32 (a vertex count within limits is far below 2^31)
    normals: np.ndarray    # (V, 3) unit shading normals, or None for flat shading
    uvs: np.ndarray = None   # (V, 2) texture coordinates (Mitsuba's convention), or None
    # normals and uvs are float64 while a shape is made, float32 in a scene (kept_in_scene).

    def __post_init__(self):
        self.faces = np.asarray(self.faces, np.int32)   # half an int64 array's memory


def kept_in_scene(mesh):
    """The mesh as a scene keeps it once its transform is applied: normals and texture
    coordinates in float32, which is all the kernel and the exported files take of them (half
    the memory, the same scene arrays bit for bit). Spheres as they are."""
    if not isinstance(mesh, Mesh):
        return mesh
    return Mesh(mesh.vertices, mesh.faces, None if mesh.normals is None else mesh.normals.astype(np.float32),
                None if mesh.uvs is None else mesh.uvs.astype(np.float32))


@dataclass
class MeshData:
    """A mesh as a file gives it (obj_reader.py, ply_reader.py, serialized.py, trimesh), before
    load_mesh_file checks it and decides its texture coordinates and shading normals."""
    positions: np.ndarray   # (V, 3) float64
    faces: np.ndarray       # (F, 3) int64
    uvs: np.ndarray         # (V, 2) float64 as stored (not flipped), or None
    normals: np.ndarray     # (V, 3) float64 as stored (not normalised), or None


@dataclass
class Sphere:
    """An analytic sphere (kernels/sphere.h): exact surface and normals."""
    center: np.ndarray     # (3,) float64, world space
    radius: float          # > 0
    flipped: bool = False  # the front face (normals, one-sided emission) is inside
    # Object-to-world rotation (orthonormal; a mirror has determinant -1): the frame of the
    # texture coordinates (sphere_uv), Mitsuba's to_world without its scale and translation.
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))


def sphere_uv(sphere, points):
    """Mitsuba's texture coordinates of points (N, 3) on a sphere: in its object frame,
    u = phi / 2 pi (phi = atan2(y, x) in [0, 2 pi)) and v = theta / pi (theta from +z)."""
    local = (np.asarray(points, dtype=float) - sphere.center) @ sphere.rotation / sphere.radius
    phi = np.arctan2(local[:, 1], local[:, 0])
    phi = np.where(phi < 0, phi + 2 * np.pi, phi)
    theta = np.arccos(np.clip(local[:, 2] / np.linalg.norm(local, axis=1), -1, 1))
    return np.stack([phi / (2 * np.pi), theta / np.pi], axis=1)


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
                      linear @ mesh.rotation / scale)
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


def _face_normals_and_angles(vertices, faces):
    """Unit normals (3, F) of triangles and their angles (3, F) at their three corners; angles
    of faces of zero area, and angles below 1e-8, are 0 (they do not count in vertex_normals)."""
    # Coordinates as rows (3, F): every operation below then reads contiguous memory.
    columns = np.ascontiguousarray(vertices[faces].transpose(2, 1, 0))   # (3 axes, 3 corners, F)
    p0, p1, p2 = columns[:, 0], columns[:, 1], columns[:, 2]
    face_normals = _unit_columns(_cross(p1 - p0, p2 - p0))
    u = _unit_columns(p1 - p0)
    v = _unit_columns(p2 - p0)
    w = _unit_columns(p2 - p1)
    angles = np.empty((3, len(faces)))
    angles[0] = np.arccos(np.clip(_dot(u, v), -1, 1))
    angles[1] = np.arccos(np.clip(-_dot(u, w), -1, 1))
    angles[2] = np.pi - angles[0] - angles[1]
    angles[:, np.any(angles < 1e-8, axis=0)] = 0.0
    angles[:, _dot(face_normals, face_normals) <= 0.5] = 0.0
    return face_normals, angles


def _normalized(v):
    """Rows of (N, 3) scaled to unit length (zero rows stay zero)."""
    return _unit_columns(v.T).T


def _unit_columns(v):
    """Columns of (3, N) scaled to unit length (zero columns stay zero)."""
    length = np.sqrt(_dot(v, v))   # np.linalg.norm's sum, without its overhead
    return v / np.where(length > 0, length, 1.0)


def _dot(a, b):
    """Dot products of the columns of (3, N) arrays."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    """Cross products of the columns of (3, N) arrays (np.cross's arithmetic)."""
    return np.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def icosphere(center=(0, 0, 0), radius=1.0, subdivisions=4, smooth=True):
    """Icosphere; smooth: shading normals are the exact sphere normals, else flat facets. No
    texture coordinates (an analytic Sphere has Mitsuba's)."""
    import trimesh

    unit = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    v = _normalized(np.asarray(unit.vertices, dtype=float))
    return Mesh(v * radius + np.asarray(center, dtype=float), np.asarray(unit.faces), v if smooth else None)


def rectangle():
    """The square [-1, 1]^2 in the plane z = 0, facing +z; uv = ((x + 1) / 2, (y + 1) / 2), as
    Mitsuba's rectangle (exact: the map is linear)."""
    v = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=float)
    return Mesh(v, np.array([[0, 1, 2], [0, 2, 3]]), None, (v[:, :2] + 1) / 2)


def disk(segments=128):
    """The unit disk in the plane z = 0, facing +z: a fan of `segments` triangles whose polygon
    has the disk's area (pi), so an emitting disk has the exact power.

    Mitsuba's disk is analytic, with uv = (r, phi / 2 pi), phi in [0, 2 pi) from +x towards +y.
    The fan carries those values at its vertices and interpolates them linearly. u is r at the
    rim (the rim's radius, slightly above 1) and 0 at the centre: exact along the edges from the
    centre, at most a factor 1 / cos(pi / segments) too large inside (3e-4 at 128 segments).
    v cannot be exact: the centre has no angle. Each triangle has its own centre vertex with
    v at the triangle's middle angle, so v is exact on the rim and on the line to the middle of
    the triangle's rim edge, and off by up to half the triangle's angle, 1 / (2 segments),
    towards the centre. The last triangle ends at a copy of the first rim vertex with v = 1, so v
    never interpolates across the seam at phi = 0."""
    angles = 2 * np.pi * np.arange(segments + 1) / segments
    radius = np.sqrt(2 * np.pi / (segments * np.sin(2 * np.pi / segments)))
    rim = np.stack([radius * np.cos(angles), radius * np.sin(angles), np.zeros(segments + 1)], axis=1)
    rim[segments] = rim[0]   # the seam's copy: the same point exactly
    vertices = np.concatenate([np.zeros((segments, 3)), rim])
    index = np.arange(segments)
    faces = np.stack([index, segments + index, segments + index + 1], axis=1)
    uvs = np.concatenate([np.stack([np.zeros(segments), (index + 0.5) / segments], axis=1),
                          np.stack([np.full(segments + 1, radius), angles / (2 * np.pi)], axis=1)])
    return Mesh(vertices, faces, None, uvs)


# Mitsuba's cube (src/shapes/cube.cpp, read back with mi.traverse): per face four corners, uv
# (0, 1), (1, 1), (1, 0), (0, 0), triangles (0, 1, 2) and (3, 0, 2), faces -y, +y, +x, +z, -x, -z.
_CUBE_CORNERS = np.array([
    [1, -1, -1], [1, -1, 1], [-1, -1, 1], [-1, -1, -1],
    [1, 1, -1], [-1, 1, -1], [-1, 1, 1], [1, 1, 1],
    [1, -1, -1], [1, 1, -1], [1, 1, 1], [1, -1, 1],
    [1, -1, 1], [1, 1, 1], [-1, 1, 1], [-1, -1, 1],
    [-1, -1, 1], [-1, 1, 1], [-1, 1, -1], [-1, -1, -1],
    [1, 1, -1], [1, -1, -1], [-1, -1, -1], [-1, 1, -1]], dtype=float)


def box():
    """The cube [-1, 1]^3 with outward-facing flat faces: Mitsuba's cube, vertex for vertex
    (order, winding and texture coordinates)."""
    faces = (4 * np.arange(6)[:, None, None] + np.array([[0, 1, 2], [3, 0, 2]])).reshape(-1, 3)
    uvs = np.tile([[0, 1], [1, 1], [1, 0], [0, 0]], (6, 1)).astype(float)
    return Mesh(_CUBE_CORNERS.copy(), faces, None, uvs)


# Faces whose normals and angles vertex_normals computes at a time (a few MB of temporaries).
NORMALS_BLOCK = 1 << 16

# Mitsuba's default of `flip_tex_coords` (v -> 1 - v) per file format: its obj shape flips, its ply
# shape does not, its serialized shape has no such option (and flips nothing). Formats Mitsuba
# does not read come through trimesh, whose texture coordinates follow OBJ's convention.
FLIP_TEX_COORDS = {".obj": True, ".ply": False, ".serialized": False}
_FLIP_V_SCALE, _FLIP_V_OFFSET = np.array([1.0, -1.0]), np.array([0.0, 1.0])   # v -> 1 - v


def load_mesh_file(path: Path, smooth: bool, flip_tex_coords=None, shape_index=0):
    """Load a mesh file: OBJ, PLY and Mitsuba serialized files as Mitsuba 3 reads them
    (obj_reader.py, ply_reader.py, serialized.py: texture coordinates, the file's normals, UV
    seams split into separate vertices), glTF/GLB/STL/OFF with trimesh (all meshes of a file
    merged). `smooth`: shading normals, the file's where it has them (as Mitsuba uses them),
    else computed; otherwise flat. `flip_tex_coords`: v -> 1 - v, None for Mitsuba's default of
    the format (FLIP_TEX_COORDS). `shape_index`: the shape of a serialized file.

    Raises ValueError with a message meant for the user when the file is malformed or holds no
    triangles, a vertex that is not a finite float32 number, or a face naming a vertex that does
    not exist."""
    check_regular_file(path, "mesh file", limits.MAX_MESH_FILE_BYTES)
    suffix = Path(path).suffix.lower()
    if suffix == ".obj":
        from .obj_reader import read_obj as read
    elif suffix == ".ply":
        from .ply_reader import read_ply as read
    elif suffix == ".serialized":
        from .serialized import load_serialized

        def read(path):
            return load_serialized(path, shape_index)
    else:
        read = _read_with_trimesh
    loaded = read(path)
    if len(loaded.faces) == 0:
        raise ValueError("the file holds no triangles")
    uvs = loaded.uvs
    if uvs is not None and (FLIP_TEX_COORDS.get(suffix, True) if flip_tex_coords is None else flip_tex_coords):
        uvs = uvs * _FLIP_V_SCALE + _FLIP_V_OFFSET
    return _checked_mesh(loaded.positions, loaded.faces, smooth, loaded.normals, uvs)


def _read_with_trimesh(path):
    """A mesh file of another format: texture coordinates in OBJ's convention, no normals
    (trimesh's are computed, not the file's)."""
    import trimesh

    with np.errstate(all="ignore"):   # a malformed file is reported below, not by numpy warnings
        loaded = trimesh.load(str(path), force="mesh", process=False)
    vertices = np.asarray(loaded.vertices, dtype=float)
    faces = np.asarray(loaded.faces, dtype=np.int64)
    if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError(f"expected 3D vertices and triangles, got vertices of shape {vertices.shape} "
                         f"and faces of shape {faces.shape}")
    if len(faces) and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise ValueError(f"a face refers to a vertex that does not exist (the file has {len(vertices)})")
    uvs = getattr(loaded.visual, "uv", None)
    if uvs is not None and np.shape(uvs) != (len(vertices), 2):
        uvs = None
    return MeshData(vertices, faces, None if uvs is None else np.asarray(uvs, dtype=float), None)


def _checked_mesh(vertices, faces, smooth, normals=None, uvs=None):
    """A Mesh of valid triangles (faces name existing vertices) with finite float32 texture
    coordinates (or None) and, when `smooth`, unit shading normals: `normals` (the file's) where
    they have a direction, computed ones elsewhere. ValueError for a vertex that is not a finite
    float32 point or a texture coordinate that is not a finite float32 pair."""
    for name, values in (("vertex", vertices), ("texture coordinate", uvs)):
        if values is None:
            continue
        within = np.abs(values) <= limits.FLOAT32_MAX   # false for NaN and infinities too
        if not within.all():
            index = int(np.flatnonzero(~within.all(axis=1))[0])
            raise ValueError(f"{name} {index + 1} is not finite in float32: {values[index].tolist()}")
    if not smooth:
        return Mesh(vertices, faces, None, uvs)
    if normals is None:
        return Mesh(vertices, faces, vertex_normals(vertices, faces), uvs)
    with np.errstate(all="ignore"):
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        usable = np.isfinite(length) & (length > 0)
        unit = normals / np.where(usable, length, 1.0)
    if not usable.all():   # computed normals only where the file's have no direction
        unit = np.where(usable, unit, vertex_normals(vertices, faces))
    return Mesh(vertices, faces, unit, uvs)


def vertex_normals(vertices, faces):
    """Unit shading normals: at each vertex, the unit normals of the faces around it weighted by
    the face's angle at that vertex (Thuerrner and Wuethrich 1998, as Mitsuba and trimesh compute
    them, but without scipy). Faces of zero area, or with an angle below 1e-8, do not contribute;
    a vertex whose faces cancel (or that has none) gets +x, as in Mitsuba."""
    face_normals = np.empty((3, len(faces)))
    angles = np.empty((3, len(faces)))
    # In blocks of faces: the corners and edges of a block are temporaries, not arrays over the
    # whole mesh (a third of a 3M-triangle scene's peak memory was this function's).
    for start in range(0, len(faces), NORMALS_BLOCK):
        block = slice(start, start + NORMALS_BLOCK)
        face_normals[:, block], angles[:, block] = _face_normals_and_angles(vertices, faces[block])
    summed = np.stack([sum(np.bincount(faces[:, k], angles[k] * face_normals[axis], len(vertices))
                           for k in range(3)) for axis in range(3)], axis=1)
    summed[~np.any(summed != 0, axis=1)] = [1, 0, 0]   # no direction (faces cancel, or none): Mitsuba's choice
    return _normalized(summed)
