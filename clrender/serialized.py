"""Mitsuba's `serialized` mesh files, read as Mitsuba 3's `serialized` shape reads them.

A file holds shapes one after another, each a 16-bit format tag (0x041C), a 16-bit version (3 or
4) and a zlib stream of:
    uint32 flags               (below)
    name                       version 4 only: UTF-8, NUL-terminated
    uint64 vertex count, uint64 triangle count
    positions                  3 per vertex, float32 or float64 (the precision flags)
    normals                    3 per vertex, if HAS_NORMALS
    texture coordinates        2 per vertex, if HAS_TEXCOORDS (as stored: Mitsuba flips nothing)
    colours                    3 per vertex, if HAS_COLORS (skipped)
    triangles                  3 uint32 vertex indices each
and at the end of the file a dictionary: the offset of every shape (uint32 in version 3, uint64 in
version 4) and a uint32 count of shapes. All little-endian. The FACE_NORMALS flag is ignored, as
Mitsuba 3 ignores it (its `face_normals` parameter decides).

Hostile files get a SerializedError, never an allocation the file cannot justify: the counts are
checked against what the compressed bytes could hold (zlib expands at most ~1032:1) before
anything is decompressed, and decompression stops at the size the counts give.
"""
import struct
import zlib
from pathlib import Path

import numpy as np

from .limits import MAX_TRIANGLES
from .meshes import MeshData

FORMAT_TAG = 0x041C
VERSIONS = (3, 4)
HAS_NORMALS, HAS_TEXCOORDS, HAS_COLORS = 0x0001, 0x0002, 0x0008
SINGLE_PRECISION, DOUBLE_PRECISION = 0x1000, 0x2000
MAX_ZLIB_RATIO = 1032      # the most a zlib stream can expand (deflate's limit, plus framing)
MAX_NAME = 1 << 16


class SerializedError(ValueError):
    """A malformed serialized file or a shape index it does not have."""


def shape_count(path):
    """How many shapes the file's dictionary lists."""
    data = Path(path).read_bytes()
    return _dictionary(data, _version(data, 0))[1]


def load_serialized(path, shape_index=0):
    """Shape `shape_index` of a serialized file (see the module's docstring)."""
    data = Path(path).read_bytes()
    version = _version(data, 0)
    offset = 0
    if shape_index != 0:   # as Mitsuba: the first shape is read without the dictionary
        offsets, count = _dictionary(data, version)
        if not 0 <= shape_index < count:
            raise SerializedError(f"shape_index {shape_index} is out of range: the file has {count} "
                                  f"shape{'s' if count != 1 else ''} (0..{count - 1})")
        offset = offsets[shape_index]
        version = _version(data, offset)
    return _read_shape(data, offset + 4, version)


def _version(data, offset):
    if offset == 0 and len(data) < 4:
        raise SerializedError(f"not a Mitsuba serialized mesh (the file has {len(data)} bytes)")
    if offset + 4 > len(data):
        raise SerializedError(f"a shape offset ({offset}) lies outside the file ({len(data)} bytes)")
    tag, version = struct.unpack_from("<HH", data, offset)
    if tag != FORMAT_TAG:
        raise SerializedError("not a Mitsuba serialized mesh (bad format tag)" if offset == 0
                              else f"no shape at offset {offset} (bad format tag)")
    if version not in VERSIONS:
        raise SerializedError(f"unsupported serialized format version {version} (supported: 3, 4)")
    return version


def _dictionary(data, version):
    """(offsets, count) from the end-of-file dictionary."""
    if len(data) < 8:
        raise SerializedError("the file is too short for a shape dictionary")
    count = struct.unpack_from("<I", data, len(data) - 4)[0]
    width = 4 if version == 3 else 8
    if count == 0 or count * width + 4 > len(data) - 4:
        raise SerializedError(f"the end-of-file dictionary lists {count} shapes, which the file cannot hold "
                              "(truncated or corrupt?)")
    offsets = np.frombuffer(data, "<u4" if version == 3 else "<u8", count, len(data) - 4 - count * width)
    return [int(offset) for offset in offsets], count


class _Inflater:
    """Reads a zlib stream in exact-size pieces, never more than asked for."""

    def __init__(self, data, offset):
        self.stream = zlib.decompressobj()
        self.pending = memoryview(data)[offset:]
        self.compressed = len(data) - offset

    def read(self, size):
        pieces, got = [], 0
        while got < size:
            try:
                piece = self.stream.decompress(self.pending, size - got)
            except zlib.error as e:
                raise SerializedError(f"corrupt compressed data ({e})") from None
            self.pending = self.stream.unconsumed_tail
            if not piece:
                raise SerializedError("the shape's data ends early (truncated or corrupt?)")
            pieces.append(piece)
            got += len(piece)
        return b"".join(pieces)

    def finish(self):
        """Raise unless the stream ends here, its checksum right: corrupt data is caught even
        where it decompresses to the sizes expected."""
        try:
            extra = self.stream.decompress(self.pending, 1)
        except zlib.error as e:
            raise SerializedError(f"corrupt compressed data ({e})") from None
        if extra or not self.stream.eof:
            raise SerializedError("the shape's data goes on beyond its counts (corrupt?)")

    def skip_name(self):
        """Past the NUL-terminated name of a version 4 shape (clrender names shapes itself)."""
        for _ in range(MAX_NAME):
            if self.read(1) == b"\0":
                return
        raise SerializedError("the shape's name is not terminated")


def _read_shape(data, offset, version):
    inflater = _Inflater(data, offset)
    flags = struct.unpack("<I", inflater.read(4))[0]
    if version == 4:
        inflater.skip_name()
    vertex_count, face_count = struct.unpack("<QQ", inflater.read(16))
    if face_count > MAX_TRIANGLES:
        raise SerializedError(f"the shape claims {face_count} triangles, more than the {MAX_TRIANGLES} clrender takes")
    if (flags & SINGLE_PRECISION) and (flags & DOUBLE_PRECISION):
        raise SerializedError("the shape claims both single and double precision")
    real = "<f8" if flags & DOUBLE_PRECISION else "<f4"
    per_vertex = 3 + 3 * bool(flags & HAS_NORMALS) + 2 * bool(flags & HAS_TEXCOORDS) + 3 * bool(flags & HAS_COLORS)
    size = vertex_count * per_vertex * np.dtype(real).itemsize + face_count * 12
    if size > MAX_ZLIB_RATIO * inflater.compressed:
        raise SerializedError(f"the shape claims {vertex_count} vertices and {face_count} triangles, more than "
                              f"its {inflater.compressed} compressed bytes can hold (corrupt?)")

    def array(width, dtype=real):
        return np.frombuffer(inflater.read(vertex_count * width * np.dtype(dtype).itemsize), dtype).reshape(-1, width)

    positions = array(3).astype(float)
    normals = array(3).astype(float) if flags & HAS_NORMALS else None
    uvs = array(2).astype(float) if flags & HAS_TEXCOORDS else None
    if flags & HAS_COLORS:
        array(3)
    faces = np.frombuffer(inflater.read(face_count * 12), "<u4").reshape(-1, 3).astype(np.int64)
    inflater.finish()
    if len(faces) and faces.max() >= vertex_count:
        raise SerializedError(f"a triangle names vertex {int(faces.max())} of {vertex_count}")
    return MeshData(positions, faces, uvs, normals)
