"""A scene's shapes as one disk-cache entry (disk_cache.py, kind "shapes"), for scenes of many
shapes: the staircase's 775 shapes (774 OBJ files) spent 0.3 s of its 0.5 s load on Python work
per shape (its cached mesh read and checked, its transform parsed and applied), which one entry
read in one piece replaces (docs/performance.md).

The key holds every shape's description as the scene reader gets it, what those descriptions
refer to (material and medium names, the folder of relative paths) and the bytes of each mesh
file (by hash), with the source of the code that reads them: an entry is never stale, and a
scene that differs in any of these is read shape by shape (and stored again). A description
that is not plain data, or a mesh file that cannot be read within the limits, gets no key: the
shape reader then says what is wrong, with its place."""
import hashlib
import json
import os
import sys

import numpy as np

from . import disk_cache, limits, meshes, obj_reader, ply_reader, serialized
from .files import not_a_file, resolved

# Below this many shapes the per-shape work is too little to pay for a second copy of the meshes.
MIN_SHAPES = 32
# Beyond this many bytes of mesh files the entry would double a large scene's memory while it is
# stored and its disk use, and hashing the files costs a second a gigabyte: such scenes are read
# shape by shape (their time is in parsing and the BVH, not per shape).
MAX_FILE_BYTES = 256 << 20

# Mesh files by suffix whose readers the key's code digest covers (others come through trimesh).
_CACHED_SUFFIXES = (".obj", ".ply", ".serialized")


def key(descriptions, references, base_dir):
    """The entry's key for the shape `descriptions` (the scene's "shapes" list) that name
    `references` (material names, medium names, the scene's medium) with relative paths from
    `base_dir`, or None: too few shapes, more than MAX_FILE_BYTES of mesh files, or a description
    that is not plain data or names a mesh file that is not a readable regular file within
    limits.MAX_MESH_FILE_BYTES."""
    if len(descriptions) < MIN_SHAPES:
        return None
    try:
        text = json.dumps([descriptions, references], sort_keys=True, default=_plain)
        paths = [resolved(base_dir / d["file"]) for d in descriptions
                 if isinstance(d, dict) and d.get("type") == "mesh"]
        sizes = [_cached_file_size(path) for path in paths]
        if None in sizes or sum(sizes) > MAX_FILE_BYTES:
            return None
        digests = {}   # a file that many shapes name is read once
        for path in paths:
            if path not in digests:
                digests[path] = _file_digest(path)
        files = [digests[path] for path in paths]
    except (TypeError, ValueError, KeyError, OSError, RecursionError):   # hostile data: the reader says why
        return None
    from . import scene   # the reader of the descriptions (which imports this module)

    code = disk_cache.code_digest(sys.modules[__name__], scene, meshes, obj_reader, ply_reader, serialized, limits)
    return disk_cache.key("shapes", code, text, os.fspath(base_dir), tuple(files))


def _plain(value):
    """json.dumps' fallback: numpy values as the lists and numbers they hold."""
    if isinstance(value, (np.ndarray, np.generic)):
        return value.tolist()
    raise TypeError(f"not plain data: {type(value).__name__}")


def _cached_file_size(path):
    """The size of a mesh file, or None (not a regular file of a cached format within the size
    limit)."""
    # not_a_file as the shape reader checks it: it records the file among the scene's inputs
    # (files.recording_inputs) on a cache hit too.
    if os.path.splitext(path)[1].lower() not in _CACHED_SUFFIXES or not_a_file(path) is not None:
        return None
    size = os.stat(path).st_size
    return size if size <= limits.MAX_MESH_FILE_BYTES else None


def _file_digest(path):
    """The SHA-256 of a file's bytes."""
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def load(entry_key):
    """The shapes stored under `entry_key`, as (name, material, mesh, interior, exterior) tuples,
    or None (absent or damaged). Their arrays are read-only views of the entry."""
    arrays = disk_cache.load_arrays("shapes", entry_key)
    if arrays is None:
        return None
    try:
        records = json.loads(bytes(arrays["records"]))
        return [_shape(record, arrays) for record in records]
    except (ValueError, TypeError, KeyError, IndexError):   # written by other code
        return None


def _shape(record, arrays):
    name, material, interior, exterior, mesh = record
    if mesh["kind"] == "sphere":
        geometry = meshes.Sphere(np.array(mesh["center"]), mesh["radius"], mesh["flipped"], np.array(mesh["rotation"]))
    else:
        def part(field):
            start, stop = mesh[field]
            return None if start < 0 else arrays[field][start:stop]
        geometry = meshes.Mesh(part("vertices"), part("faces"), part("normals"), part("uvs"))
    return name, material, geometry, interior, exterior


def store(entry_key, shapes):
    """Write `shapes` ((name, material, mesh, interior, exterior) tuples) under `entry_key`: each
    mesh array concatenated with its kind, the records (names, indices, row ranges) as JSON."""
    parts = {"vertices": [], "faces": [], "normals": [], "uvs": []}
    rows = dict.fromkeys(parts, 0)
    records = []
    for name, material, geometry, interior, exterior in shapes:
        if isinstance(geometry, meshes.Sphere):
            mesh = {"kind": "sphere", "center": geometry.center.tolist(), "radius": float(geometry.radius),
                    "flipped": bool(geometry.flipped), "rotation": np.asarray(geometry.rotation).tolist()}
        else:
            mesh = {"kind": "mesh"}
            for field, array in (("vertices", geometry.vertices), ("faces", geometry.faces),
                                 ("normals", geometry.normals), ("uvs", geometry.uvs)):
                if array is None:
                    mesh[field] = (-1, -1)
                    continue
                mesh[field] = (rows[field], rows[field] + len(array))
                rows[field] += len(array)
                parts[field].append(array)
        records.append((name, int(material), int(interior), int(exterior), mesh))
    columns = {"vertices": (3, np.float64), "faces": (3, np.int32), "normals": (3, np.float32), "uvs": (2, np.float32)}
    arrays = {field: np.concatenate(parts[field]).astype(dtype, copy=False) if parts[field]
              else np.zeros((0, width), dtype) for field, (width, dtype) in columns.items()}
    arrays["records"] = np.frombuffer(json.dumps(records).encode(), np.uint8)
    disk_cache.store_arrays("shapes", entry_key, arrays)
