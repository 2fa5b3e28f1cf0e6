"""Mesh files written as their formats define them, for the tests of the readers
(tests/test_mesh_files.py) and the fuzz tests (tests/test_fuzz.py)."""
import struct
import zlib
from pathlib import Path

import numpy as np

PLY_TYPES = {"float": "f4", "double": "f8", "uchar": "u1", "int": "i4", "uint": "u4", "short": "i2"}


def write_ply_file(path, encoding, vertex, faces, count_type="uchar", index_type="int", extra_element=False):
    """A PLY file of `vertex` (name -> (type, values)) and polygons `faces` (lists of indices),
    ascii or binary_little_endian/binary_big_endian; `extra_element`: an element before the
    vertices that readers must skip (with a list property)."""
    names = list(vertex)
    count = len(next(iter(vertex.values()))[1])
    header = ["ply", f"format {encoding} 1.0", "comment made by a test"]
    if extra_element:
        header += ["element material 2", "property list uchar float weights", "property uchar id"]
    header += [f"element vertex {count}"] + [f"property {vertex[n][0]} {n}" for n in names]
    header += [f"element face {len(faces)}", f"property list {count_type} {index_type} vertex_indices", "end_header"]
    order = {"binary_little_endian": "<", "binary_big_endian": ">"}.get(encoding)
    if order is None:
        rows = (["3 0.5 0.25 1 7", "0 8"] if extra_element else [])
        rows += [" ".join(repr(float(vertex[n][1][i])) if vertex[n][0] in ("float", "double") else str(int(vertex[n][1][i]))
                          for n in names) for i in range(count)]
        rows += [" ".join(str(x) for x in [len(f)] + list(f)) for f in faces]
        body = ("\n".join(rows) + "\n").encode()
    else:
        body = b""
        if extra_element:
            body += struct.pack(order + "B3fB", 3, 0.5, 0.25, 1, 7) + struct.pack(order + "BB", 0, 8)
        table = np.zeros(count, [(n, order + PLY_TYPES[vertex[n][0]]) for n in names])
        for n in names:
            table[n] = vertex[n][1]
        body += table.tobytes()
        for f in faces:
            body += np.array([len(f)], order + PLY_TYPES[count_type]).tobytes() + np.array(f, order + PLY_TYPES[index_type]).tobytes()
    Path(path).write_bytes(("\n".join(header) + "\n").encode() + body)


def write_serialized(path, shapes, version=4):
    """A serialized file of `shapes` (dicts: positions, faces, optional normals, uvs, colors,
    double, face_normals, name), as Mitsuba's format defines it."""
    out, offsets = b"", []
    for shape in shapes:
        offsets.append(len(out))
        real = "<f8" if shape.get("double") else "<f4"
        flags = 0x2000 if shape.get("double") else 0x1000
        arrays = [np.asarray(shape["positions"], real)]
        for key, flag in (("normals", 0x1), ("uvs", 0x2), ("colors", 0x8)):
            if shape.get(key) is not None:
                flags |= flag
                arrays.append(np.asarray(shape[key], real))
        flags |= 0x10 if shape.get("face_normals") else 0
        body = struct.pack("<I", flags) + ((shape.get("name", "").encode() + b"\0") if version == 4 else b"")
        body += struct.pack("<QQ", len(shape["positions"]), len(shape["faces"]))
        body += b"".join(a.tobytes() for a in arrays) + np.asarray(shape["faces"], "<u4").tobytes()
        out += struct.pack("<HH", 0x041C, version) + zlib.compress(body)
    out += np.array(offsets, "<u4" if version == 3 else "<u8").tobytes() + struct.pack("<I", len(shapes))
    Path(path).write_bytes(out)
