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

The file is read with numpy over its whole text, not line by line: the statements of each kind
are picked out by their lines' first bytes, and a file whose statements are all of the plain
forms (numbers only, every face's corners of one form, no comments) is checked and parsed as
arrays (_plain_statements). Any other file, a malformed one included, is read with regular
expressions (_general_statements), which name the line at fault. Both give the same values.
"""
import hashlib
import re
import sys
import warnings
from pathlib import Path

import numpy as np

from . import disk_cache, meshes
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
    """The triangle mesh of an OBJ file (see the module's docstring); ObjError when malformed.
    A file's mesh is parsed once: later reads of the same bytes load it from the disk cache,
    keyed by the bytes and the parser's code (parsing was most of the load time of a scene of
    hundreds of OBJ files: docs/performance.md)."""
    text = Path(path).read_bytes()
    entry = disk_cache.key("obj", disk_cache.code_digest(sys.modules[__name__], meshes),
                           hashlib.sha256(text).hexdigest())
    cached = disk_cache.load_arrays("meshes", entry)
    if cached is not None:
        return MeshData(**cached)
    mesh = parse_obj(text)
    disk_cache.store_arrays("meshes", entry, vars(mesh))
    return mesh


def parse_obj(text):
    """The triangle mesh of an OBJ file's bytes (read_obj)."""
    if b"\0" in text:
        raise ObjError("not a text file (it holds NUL bytes)")
    text = _statement_text(text)
    positions, texcoords, normals, (corners, sizes, given) = _plain_statements(text) or _general_statements(text)
    if not len(sizes):
        raise ObjError("the file holds no faces")
    _check_indices(text, sizes, np.any(given & (corners == 0), axis=1), "index 0 (indices start at 1)")
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


def _statement_text(text):
    """The file's text with a line break before its first line and its lines' indents removed:
    every statement then starts with a line break and its keyword."""
    return _INDENT.sub(b"\n", b"\n" + text)


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


def _byte_set(characters):
    table = np.zeros(256, bool)
    table[list(characters)] = True
    return table


# The plain forms' bytes (no comments, no inf or nan: every byte but a gap is above b" "), and
# corners' forms: (slashes, pairs of adjacent slashes) -> the indices given (p, p/t, p/t/n, p//n).
_KEYWORDS = (b"v", b"vt", b"vn", b"f")
_NUMBER_BYTES = b"0123456789.+-eE \t\r\n"
_INDEX_BYTES = b"0123456789+-/ \t\r\n"
_IS_BLANK = _byte_set(b" \t")   # what follows a keyword
_NUMBERS_PER_LINE = {b"v": (3, np.inf), b"vt": (2, 3), b"vn": (3, 3)}   # (fewest, most); the first `fewest` kept
_CORNER_FORMS = {(0, 0): [0], (1, 0): [0, 1], (2, 0): [0, 1, 2], (2, 1): [0, 2]}


def _plain_statements(text):
    """What _general_statements gives, for a file whose statements are all plain (see the
    module's docstring), without regular expressions; None for any other file."""
    buf = np.frombuffer(text, np.uint8)
    breaks = (buf == ord("\n")).nonzero()[0]
    kinds = _line_kinds(buf, breaks)
    read = []
    for kind, key in enumerate(_KEYWORDS, start=1):
        body, body_breaks = _bodies(buf, breaks, kinds == kind, len(key))
        data = body.tobytes()
        if data.translate(None, _INDEX_BYTES if key == b"f" else _NUMBER_BYTES) or not _returns_end_lines(body, data):
            return None
        starts, per_line = _tokens(body, body_breaks)
        read.append(_plain_faces(body, data, starts, per_line) if key == b"f" else
                    _plain_numbers(data, per_line, *_NUMBERS_PER_LINE[key]))
        if read[-1] is None:
            return None
    return read


def _line_kinds(buf, breaks):
    """The kind of statement of each line: 1 + the index of its keyword in _KEYWORDS, 0 for other
    lines. A line here is a line break and what follows it up to the next (read_obj puts one
    before the first line)."""
    # A keyword's letters and the gap after it; an index past the end reads the last byte
    # instead, a letter of the keyword, which no statement has there.
    first, second, third = (buf[np.minimum(breaks + k, len(buf) - 1)] for k in (1, 2, 3))
    v = first == ord("v")
    kinds = np.zeros(len(breaks), np.uint8)
    kinds[v & _IS_BLANK[second]] = 1
    kinds[v & (second == ord("t")) & _IS_BLANK[third]] = 2
    kinds[v & (second == ord("n")) & _IS_BLANK[third]] = 3
    kinds[(first == ord("f")) & _IS_BLANK[second]] = 4
    return kinds


def _bodies(buf, breaks, chosen, keyword_length):
    """The `chosen` lines, one after another, their keywords blanked out (a copy: one slice
    where they follow each other, as exporters write them), and where their line breaks are."""
    lines = chosen.nonzero()[0]
    if not len(lines):
        return np.zeros(0, np.uint8), lines
    if lines[-1] - lines[0] + 1 == len(lines):
        stop = breaks[lines[-1] + 1] if lines[-1] + 1 < len(breaks) else len(buf)
        body = buf[breaks[lines[0]]:stop].copy()
        body_breaks = breaks[lines[0]:lines[-1] + 1] - breaks[lines[0]]
    else:
        body = buf[np.repeat(chosen, np.diff(breaks, append=len(buf)))]
        body_breaks = (body == ord("\n")).nonzero()[0]
    body[body_breaks[:, None] + np.arange(1, keyword_length + 1)] = ord(" ")
    return body, body_breaks


def _returns_end_lines(body, data):
    """Whether every carriage return ends its line (one in a line is malformed)."""
    if b"\r" not in data:
        return True
    returns = (body[:-1] == ord("\r")).nonzero()[0]
    return bool((body[returns + 1] == ord("\n")).all())


def _tokens(body, breaks):
    """Where each run of bytes between gaps starts, and how many start on each line (of plain
    bytes only: the gaps are those up to b" ")."""
    gap = body <= ord(" ")
    starts = (gap[:-1] & ~gap[1:]).nonzero()[0] + 1
    return starts, _per_run(starts, breaks)


def _per_run(positions, starts):
    """How many of the sorted `positions` fall in each run [starts[i], starts[i + 1])."""
    first = np.searchsorted(positions, starts)
    counts = np.empty_like(first)
    counts[:-1] = first[1:] - first[:-1]
    counts[-1:] = len(positions) - first[-1:]
    return counts


def _plain_numbers(data, counts, fewest, most):
    """The first `fewest` numbers of each line, (lines, fewest) float64; None unless every line
    holds fewest to most numbers."""
    if len(counts) and (counts.min() < fewest or counts.max() > most):
        return None
    values = _parsed(data, np.float64)
    if values is None or len(values) != counts.sum():
        return None
    if len(values) == fewest * len(counts):
        return values.reshape(-1, fewest)
    return values[(np.cumsum(counts) - counts)[:, None] + np.arange(fewest)]


def _plain_faces(body, data, starts, sizes):
    """_face_corners of faces whose corners all have one form, each index [-+]?digits; None for
    other faces."""
    if not len(starts):
        return np.zeros((0, 3), np.int64), np.zeros(0, np.int64), np.zeros((0, 3), bool)
    if sizes.min() < 3 or body[-1] in b"/+-":
        return None
    # Each slash between two non-gaps, each sign after a gap or slash and before a digit: then
    # every piece between gaps and slashes is an index, and the slashes say the form.
    at = (body == ord("/")).nonzero()[0]
    if (body[at - 1] <= ord(" ")).any() or (body[at + 1] <= ord(" ")).any():
        return None
    if b"+" in data or b"-" in data:
        signs = ((body == ord("+")) | (body == ord("-"))).nonzero()[0]
        before, after = body[signs - 1], body[signs + 1]
        if not (((before <= ord(" ")) | (before == ord("/"))) & (after >= ord("0")) & (after <= ord("9"))).all():
            return None
    slashes = _per_run(at, starts)
    paired = _per_run(at[1:][at[1:] - at[:-1] == 1], starts)
    form = (int(slashes[0]), int(paired[0]))
    if form not in _CORNER_FORMS or (slashes != form[0]).any() or (paired != form[1]).any():
        return None
    columns = _CORNER_FORMS[form]
    values = _parsed(data.replace(b"/", b" ") if len(at) else data, np.int64)
    if values is None or len(values) != len(starts) * len(columns):
        return None
    corners = np.zeros((len(starts), 3), np.int64)
    corners[:, columns] = values.reshape(len(starts), len(columns))
    given = np.zeros((len(starts), 3), bool)
    given[:, columns] = True
    return corners, sizes, given


def _parsed(data, dtype):
    """The numbers of `data` (numbers and gaps), None where a run between gaps is not one."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)   # older numpy warns, newer raises
        try:
            return np.fromstring(data, dtype, sep=" ")
        except (ValueError, DeprecationWarning):
            return None


def _general_statements(text):
    """(positions, texture coordinates, normals, _face_corners) of any file, read with the
    regular expressions; ObjError naming the first malformed statement."""
    return _vectors(text, b"v", 3), _vectors(text, b"vt", 2), _vectors(text, b"vn", 3), _face_corners(text)


def _face_corners(text):
    """Every face corner as (p, t, n) indices (0: not given), (C, 3) int64, the number of
    corners of each face, and which indices each corner gives, (C, 3) bool."""
    bodies = _well_formed(text, b"f")
    if not bodies:
        return np.zeros((0, 3), np.int64), np.zeros(0, np.int64), np.zeros((0, 3), bool)
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
    return corners, sizes, given


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
