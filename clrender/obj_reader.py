"""Wavefront OBJ files, read as Mitsuba 3's `obj` shape reads them.

Positions (`v`), texture coordinates (`vt`), normals (`vn`) and faces (`f`) whose corners are
`p`, `p/t`, `p//n` or `p/t/n`; polygons become fans (p0 p1 p2, p0 p2 p3, ...); every other
statement (objects, groups, materials, smoothing groups, lines) is ignored and all faces form one
mesh. As in Mitsuba, a vertex is a distinct (p, t, n) index triple, numbered in the order faces
first name it: corners that share a position but not a texture coordinate or normal (a UV seam,
a crease) are separate vertices, so values interpolated over a triangle are Mitsuba's, and
positions no face uses are dropped. Beyond Mitsuba: negative (relative) indices are resolved, and
a file that gives texture coordinates or normals on some corners only is read (Mitsuba leaves the
others undefined): corners without one get (0, 0), and normals are then computed for the whole
mesh instead of taken from the file.

The file is parsed with regular expressions over its whole text and numpy, not line by line:
a 2.3 MB OBJ file reads in a fraction of a second.
"""
import re
from pathlib import Path

import numpy as np

from .meshes import MeshData

_NUMBER = rb"[-+]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|(?i:inf|nan))"
_GAP = rb"[ \t]+"
_END = rb"[ \t\r]*(?:#[^\n]*)?(?=\n|\Z)"
_INDEX = rb"[-+]?\d+"
_CORNER = rb"(" + _INDEX + rb")(?:/(" + _INDEX + rb")?(?:/(" + _INDEX + rb"))?)?"
_CORNER_TEXT = rb"[-+]?\d+(?:/(?:[-+]?\d+)?(?:/[-+]?\d+)?)?"


def _statement(key, body):
    # Each starts with a literal (a line break and the keyword), which the regular expression
    # engine finds fast; read_obj puts a line break before the first line and removes indents.
    return re.compile(rb"\n" + key + rb"[ \t]" + body)


# Every statement of a kind (whatever follows its keyword), and the statements of that kind
# that are well formed, capturing the text of their values: the first 3 numbers of a `v` (which
# may have w or colours), the first 2 of a `vt` (which may have w), a face's corners.
_ANY = {key: _statement(key, rb"([^\n]*)") for key in (b"v", b"vt", b"vn", b"f")}


def _numbers(count):
    return rb"[ \t]*(" + _GAP.join([_NUMBER] * count) + rb")"


_WELL_FORMED = {
    b"v": _statement(b"v", _numbers(3) + rb"(?:" + _GAP + _NUMBER + rb")*" + _END),
    b"vt": _statement(b"vt", _numbers(2) + rb"(?:" + _GAP + _NUMBER + rb")?" + _END),
    b"vn": _statement(b"vn", _numbers(3) + _END),
    # (a corner, then gaps and corners: each repetition starts with a gap, so nothing backtracks)
    b"f": _statement(b"f", rb"[ \t]*(" + _CORNER_TEXT + rb"(?:" + _GAP + _CORNER_TEXT + rb"){2,})" + _END),
}
_EXPECTED = {b"v": "3 numbers", b"vt": "2 numbers", b"vn": "3 numbers",
             b"f": "3 or more corners p, p/t, p//n or p/t/n"}
_CORNERS = re.compile(_CORNER)
_INDENT = re.compile(rb"\n[ \t]+")


class ObjError(ValueError):
    """A malformed OBJ file; the message names the line."""


def read_obj(path):
    """The triangle mesh of an OBJ file (see the module's docstring); ObjError when malformed."""
    text = Path(path).read_bytes()
    if b"\0" in text:
        raise ObjError("not a text file (it holds NUL bytes)")
    text = _INDENT.sub(b"\n", b"\n" + text)
    positions = _vectors(text, b"v", 3)
    texcoords = _vectors(text, b"vt", 2)
    normals = _vectors(text, b"vn", 3)
    corners, sizes = _face_corners(text)
    if not len(sizes):
        raise ObjError("the file holds no faces")
    corners = _absolute_indices(text, corners, sizes, (len(positions), len(texcoords), len(normals)))
    first, vertex_of_corner = _distinct_rows(corners, (len(positions), len(texcoords), len(normals)))
    keys = corners[first]
    order = np.argsort(first, kind="stable")   # Mitsuba numbers vertices by first use
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    keys = keys[order]
    faces = fans(rank[vertex_of_corner.reshape(-1)], sizes)
    uvs = None
    if np.any(keys[:, 1] > 0):
        uvs = np.where(keys[:, 1:2] > 0, texcoords[np.maximum(keys[:, 1] - 1, 0)], 0.0)
    vertex_normals = None
    if np.all(keys[:, 2] > 0):
        vertex_normals = normals[keys[:, 2] - 1]
    return MeshData(positions[keys[:, 0] - 1], faces, uvs, vertex_normals)


def _distinct_rows(corners, counts):
    """(first corner of each distinct (p, t, n) triple, triple of each corner). The triples are
    numbered as one integer each where they fit in 63 bits (a 1-D unique is several times faster
    than np.unique over rows); numbering them in order of first use is left to the caller."""
    p, t, n = (int(c) + 1 for c in counts)
    if p * t * n < 2**63:
        key = (corners[:, 0] * t + corners[:, 1]) * n + corners[:, 2]
        _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    else:
        _, first, inverse = np.unique(corners, axis=0, return_index=True, return_inverse=True)
    return first, inverse.reshape(-1)


def _vectors(text, key, width):
    """The values of every `key` statement, (N, width) float64."""
    values = np.fromstring(b" ".join(_well_formed(text, key)), sep=" ")   # checked: numbers only
    return values.reshape(-1, width)


def _well_formed(text, key):
    """The captured values of every `key` statement; ObjError naming the first malformed one."""
    values = _WELL_FORMED[key].findall(text)
    if len(values) != _count(text, key):
        bad = next(m for m in _ANY[key].finditer(text) if not _WELL_FORMED[key].match(text, m.start()))
        raise ObjError(f"line {_line_of(text, bad)}: cannot read {bad.group(0).decode(errors='replace').strip()!r} "
                       f"(expected {_EXPECTED[key]})")
    return values


def _count(text, key):
    """The number of `key` statements (_ANY's matches, counted without the regular expression:
    each starts at a line break, so none overlaps another)."""
    return text.count(b"\n" + key + b" ") + text.count(b"\n" + key + b"\t")


def _face_corners(text):
    """Every face corner as (p, t, n) indices (0: not given), (C, 3) int64, and the number of
    corners of each face. ObjError for an index 0 (indices start at 1)."""
    bodies = _well_formed(text, b"f")
    if not bodies:
        return np.zeros((0, 3), np.int64), np.zeros(0, np.int64)
    sizes = np.fromiter(map(len, map(bytes.split, bodies)), np.int64, len(bodies))
    joined = b" ".join(bodies)
    count = int(sizes.sum())
    slashes, doubles = joined.count(b"/"), joined.count(b"//")
    if slashes == 0 or (slashes == 2 * count and doubles in (0, count)):   # every corner p, p/t/n or p//n
        fields = np.fromstring(joined.replace(b"/", b" "), np.int64, sep=" ").reshape(count, -1)
        given = np.zeros((count, 3), bool)
        given[:, [0] if slashes == 0 else [0, 2] if doubles else [0, 1, 2]] = True
        corners = np.zeros((count, 3), np.int64)
        corners[given] = fields.reshape(-1)
    else:   # mixed forms, or p/t (which counting slashes cannot tell from mixed forms)
        corners = np.array(_CORNERS.findall(joined))
        given = corners != b""
        corners[~given] = b"0"
        corners = corners.astype(np.int64)
    _check_indices(text, sizes, np.any(given & (corners == 0), axis=1), "index 0 (indices start at 1)")
    return corners, sizes


def _absolute_indices(text, corners, sizes, counts):
    """1-based indices into each list: negative ones counted back from the statements before
    their face, as the OBJ format defines them. ObjError for an index out of range."""
    relative = corners < 0
    if np.any(relative):
        face_of_corner = np.repeat(np.arange(len(sizes)), sizes)
        face_starts = np.array([m.start() for m in _ANY[b"f"].finditer(text)])
        for column, key in enumerate((b"v", b"vt", b"vn")):
            if np.any(relative[:, column]):
                starts = np.array([m.start() for m in _ANY[key].finditer(text)], np.int64)
                before = np.searchsorted(starts, face_starts[face_of_corner[relative[:, column]]])
                corners[relative[:, column], column] += before + 1
    for column, (name, count) in enumerate(zip(("position", "texture coordinate", "normal"), counts)):
        index = corners[:, column]
        _check_indices(text, sizes, (index > count) | (relative[:, column] & (index < 1)),
                       f"a {name} beyond the {count} the file has" + (" before it" if relative[:, column].any() else ""))
    return corners


def _check_indices(text, sizes, bad, problem):
    """ObjError naming the line of the first face with a `bad` corner (one flag per corner)."""
    if np.any(bad):
        face = int(np.searchsorted(np.cumsum(sizes), np.argmax(bad), side="right"))
        match = next(m for k, m in enumerate(_ANY[b"f"].finditer(text)) if k == face)
        raise ObjError(f"line {_line_of(text, match)}: face {match.group(0).decode(errors='replace').strip()!r} "
                       f"names {problem}")


def fans(corners, sizes):
    """The triangles (first, k, k + 1) of polygons given as their corners one after another and
    their sizes, in order: Mitsuba's triangulation of OBJ polygons."""
    if np.all(sizes == 3):   # triangles already: the usual large mesh, read without index arrays
        return corners.reshape(-1, 3)
    starts = np.cumsum(sizes) - sizes
    per_face = sizes - 2
    first = np.repeat(starts, per_face)
    k = np.arange(per_face.sum()) - np.repeat(np.cumsum(per_face) - per_face, per_face)
    return corners[np.stack([first, first + k + 1, first + k + 2], axis=1)]


def _line_of(text, match):
    return text.count(b"\n", 0, match.start() + 1)   # text starts with an added line break
