"""PLY files (ASCII and binary, either byte order), read as Mitsuba 3's `ply` shape reads them.

The `vertex` element gives positions (x, y, z), normals (nx, ny, nz: used when all three are
there) and texture coordinates (the first pair found of u/v, s/t, texture_u/
texture_v: the names Mitsuba accepts); the `face` element's list `vertex_indices` (or
`vertex_index`) gives polygons. Mitsuba takes triangles only; polygons are read here as fans
(p0 p1 p2, p0 p2 p3, ...). Other elements and properties are skipped.

Every count in the header is checked against the size of the file before anything is
allocated, so a hostile header cannot ask for more memory than the file could fill.
"""
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .meshes import MeshData
from .obj_reader import fans

_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
          "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
          "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
_FORMATS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}
UV_NAMES = (("u", "v"), ("s", "t"), ("texture_u", "texture_v"))
_FACE_LISTS = ("vertex_indices", "vertex_index")
_MAX_HEADER = 1 << 20


class PlyError(ValueError):
    """A malformed PLY file."""


@dataclass
class _Property:
    name: str
    type: str               # numpy type code without byte order ("f4")
    count_type: str = None  # list properties: the type of the count


@dataclass
class _Element:
    name: str
    count: int
    properties: list


def read_ply(path):
    """The triangle mesh of a PLY file (see the module's docstring); PlyError when malformed."""
    data = Path(path).read_bytes()
    order, elements, body = _header(data)
    tables = {}
    if order is None:
        tokens, position = data[body:].split(), 0
        for element in elements:
            tables[element.name], position = _read_ascii(tokens, position, element)
        if position != len(tokens):
            raise PlyError("the file goes on after its last element")
    else:
        position = body
        for element in elements:
            tables[element.name], position = _read_binary(data, position, element, order)
    if "vertex" not in tables or "face" not in tables:
        raise PlyError("no vertex or no face element")
    return _mesh(tables["vertex"], tables["face"])


def _header(data):
    """(byte order or None for ASCII, elements, offset of the body)."""
    end = re.search(rb"end_header[ \t\r]*\n", data[:_MAX_HEADER])
    if not data.startswith(b"ply") or end is None:
        raise PlyError("not a PLY file (no 'ply' ... 'end_header' header)")
    lines = data[:end.start()].decode("ascii", errors="replace").splitlines()[1:]
    order, elements = _MISSING, []
    for number, line in enumerate(lines, start=2):
        words = line.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        try:
            if words[0] == "format" and words[1] in _FORMATS and len(words) == 3:
                order = _FORMATS[words[1]]
            elif words[0] == "element" and len(words) == 3:
                elements.append(_Element(words[1], int(words[2]), []))
                if elements[-1].count < 0:
                    raise ValueError
            elif words[0] == "property" and elements and len(words) == 5 and words[1] == "list":
                elements[-1].properties.append(_Property(words[4], _TYPES[words[3]], _TYPES[words[2]]))
            elif words[0] == "property" and elements and len(words) == 3:
                elements[-1].properties.append(_Property(words[2], _TYPES[words[1]]))
            else:
                raise ValueError
        except (ValueError, KeyError, IndexError):
            raise PlyError(f"header line {number}: cannot read {line.strip()!r}") from None
    if order is _MISSING:
        raise PlyError("the header has no 'format' line")
    return order, elements, end.end()


_MISSING = object()


# --------------------------------------------------------------------------------------------
# Element bodies: a dict property name -> values (a list property: the flat values and the
# count of each row), and the offset after the element.
# --------------------------------------------------------------------------------------------
def _read_binary(data, offset, element, order):
    scalars = [(p.name, order + p.type) for p in element.properties if p.count_type is None]
    lists = [p for p in element.properties if p.count_type is not None]
    if not lists:
        dtype = np.dtype(scalars)
        _check_size(element, dtype.itemsize * element.count, len(data) - offset)
        table = np.frombuffer(data, dtype, element.count, offset)
        return {name: table[name] for name, _ in scalars}, offset + dtype.itemsize * element.count
    _check_size(element, element.count * sum(np.dtype(p.count_type or p.type).itemsize
                                             for p in element.properties), len(data) - offset)
    if len(lists) == 1 and element.properties[-1] is lists[0] and element.count:
        # Rows of fixed-size scalars, then one list: read at once when every list is as long
        # as the first (all triangles), which the counts read back confirm.
        prefix = np.dtype(scalars + [("_count", order + lists[0].count_type)])
        length = int(np.frombuffer(data, prefix, 1, offset)["_count"][0])
        dtype = np.dtype(scalars + [("_count", order + lists[0].count_type),
                                    ("_items", order + lists[0].type, (length,))])
        if dtype.itemsize * element.count <= len(data) - offset:
            table = np.frombuffer(data, dtype, element.count, offset)
            if np.all(table["_count"] == length):
                values = {name: table[name] for name, _ in scalars}
                values[lists[0].name] = (table["_items"].reshape(-1), table["_count"].astype(np.int64))
                return values, offset + dtype.itemsize * element.count
    return _read_binary_rows(data, offset, element, order)


def _read_binary_rows(data, offset, element, order):
    """Row by row, for lists of differing lengths."""
    columns = {p.name: [] for p in element.properties}
    counts = {p.name: [] for p in element.properties if p.count_type is not None}
    for _ in range(element.count):
        for p in element.properties:
            if p.count_type is None:
                columns[p.name].append(_unpack(data, offset, order + p.type, 1))
                offset += np.dtype(p.type).itemsize
            else:
                length = int(_unpack(data, offset, order + p.count_type, 1)[0])
                offset += np.dtype(p.count_type).itemsize
                if length < 0:
                    raise PlyError(f"element '{element.name}': a list of negative length")
                columns[p.name].append(_unpack(data, offset, order + p.type, length))
                counts[p.name].append(length)
                offset += length * np.dtype(p.type).itemsize
    return _columns(columns, counts, element), offset


def _unpack(data, offset, dtype, count):
    if offset + count * np.dtype(dtype).itemsize > len(data):
        raise PlyError("the file ends inside its data (truncated?)")
    return np.frombuffer(data, dtype, count, offset)


def _read_ascii(tokens, position, element):
    _check_size(element, element.count * len(element.properties), len(tokens) - position)
    lists = [p for p in element.properties if p.count_type is not None]
    width = len(element.properties)
    if lists and len(lists) == 1 and element.properties[-1] is lists[0] and element.count:
        width += int(_ascii_numbers(tokens[position + width - 1:position + width])[0])   # the first list's length
    table = _ascii_numbers(tokens[position:position + width * element.count]) if width else np.zeros(0)
    if len(table) == width * element.count:
        table = table.reshape(element.count, width)
        if not lists:
            return {p.name: table[:, k] for k, p in enumerate(element.properties)}, position + table.size
        count_column = len(element.properties) - 1
        if len(lists) == 1 and np.all(table[:, count_column] == width - len(element.properties)):
            values = {p.name: table[:, k] for k, p in enumerate(element.properties[:-1])}
            values[lists[0].name] = (table[:, count_column + 1:].reshape(-1),
                                     table[:, count_column].astype(np.int64))
            return values, position + table.size
    return _read_ascii_rows(tokens, position, element)


def _read_ascii_rows(tokens, position, element):
    """Row by row, for lists of differing lengths."""
    columns = {p.name: [] for p in element.properties}
    counts = {p.name: [] for p in element.properties if p.count_type is not None}
    for _ in range(element.count):
        for p in element.properties:
            length = 1
            if p.count_type is not None:
                length = _ascii_numbers(tokens[position:position + 1])
                if len(length) != 1 or length[0] < 0 or length[0] != int(length[0]):
                    raise PlyError(f"element '{element.name}': a list without a valid length")
                length = int(length[0])
                counts[p.name].append(length)
                position += 1
            columns[p.name].append(_ascii_numbers(tokens[position:position + length]))
            if len(columns[p.name][-1]) != length:
                raise PlyError("the file ends inside its data (truncated?)")
            position += length
    return _columns(columns, counts, element), position


def _ascii_numbers(tokens):
    try:
        return np.array(tokens, dtype=float)
    except ValueError:
        raise PlyError("a value that is not a number in the data") from None


def _columns(columns, counts, element):
    """The values read row by row, as whole columns (a list: flat values and counts)."""
    values = {}
    for p in element.properties:
        flat = np.concatenate(columns[p.name]) if columns[p.name] else np.zeros(0)
        values[p.name] = (flat, np.array(counts[p.name], np.int64)) if p.count_type is not None else flat
    return values


def _check_size(element, least, available):
    """Raise unless the rest of the file can hold `element` (at least `least` bytes or tokens)."""
    if least > available:
        raise PlyError(f"element '{element.name}' has {element.count} rows, more than the rest of the file holds "
                       "(truncated or corrupt?)")


# --------------------------------------------------------------------------------------------
# The mesh
# --------------------------------------------------------------------------------------------
def _mesh(vertex, face):
    missing = [name for name in "xyz" if name not in vertex]
    if missing:
        raise PlyError(f"the vertex element has no {', '.join(missing)}")
    positions = np.stack([vertex[name] for name in "xyz"], axis=1).astype(float)
    normals = None
    if all(name in vertex for name in ("nx", "ny", "nz")):
        normals = np.stack([vertex[name] for name in ("nx", "ny", "nz")], axis=1).astype(float)
    uvs = next((np.stack([vertex[u], vertex[v]], axis=1).astype(float)
                for u, v in UV_NAMES if u in vertex and v in vertex), None)
    name = next((name for name in _FACE_LISTS if isinstance(face.get(name), tuple)), None)
    if name is None:
        raise PlyError("the face element has no list 'vertex_indices'")
    indices, sizes = face[name]
    if np.any(sizes < 3):
        raise PlyError(f"face {int(np.argmax(sizes < 3))} has {int(sizes[np.argmax(sizes < 3)])} vertices")
    if len(indices) and (indices.min() < 0 or indices.max() >= len(positions) or np.any(indices != np.floor(indices))):
        raise PlyError(f"a face names a vertex that does not exist (the file has {len(positions)})")
    return MeshData(positions, fans(indices.astype(np.int64), sizes), uvs, normals)

