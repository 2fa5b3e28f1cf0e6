"""Mesh files (OBJ, PLY, Mitsuba serialized) read as Mitsuba 3 reads them: the same vertices in
the same order, triangles, texture coordinates and normals (compared with Mitsuba where it is
installed), and hostile files refused with an error naming the file, within bounded memory."""
import glob
import os
import struct
import tracemalloc
import warnings
import zlib
from pathlib import Path

import numpy as np
import pytest

import clrender
from clrender import meshes
from clrender.mitsuba_export import write_ply
from mesh_writers import write_ply_file, write_serialized

try:
    import mitsuba as mi
except ImportError:
    mi = None
needs_mitsuba = pytest.mark.skipif(mi is None, reason="Mitsuba 3 is not installed (pip install -e '.[peers]')")

# Real Mitsuba scenes written by others (not in the repository: see their SOURCES.md).
REAL_SCENES = Path(os.environ.get("CLRENDER_REAL_SCENES", "/work/shared/real-scenes"))


def real_files(pattern):
    found = sorted(glob.glob(str(REAL_SCENES / pattern)))
    return found or [pytest.param(None, marks=pytest.mark.skip(reason=f"no {pattern} under {REAL_SCENES}"))]


def mitsuba_mesh(kind, path, **parameters):
    """Mitsuba's arrays of a mesh file: positions, faces, uvs (None when empty), normals."""
    mi.set_variant("scalar_rgb")
    found = mi.traverse(mi.load_dict({"type": kind, "filename": str(path), **parameters}))
    arrays = [np.array(found[key], dtype=float) for key in ("vertex_positions", "faces", "vertex_texcoords",
                                                          "vertex_normals")]
    positions, faces, uvs, normals = (a.reshape(-1, width) for a, width in zip(arrays, (3, 3, 2, 3)))
    return positions, faces.astype(np.int64), (uvs if uvs.size else None), (normals if normals.size else None)


def assert_same_as_mitsuba(path, kind, smooth=True, flip_tex_coords=None, **parameters):
    """load_mesh_file gives Mitsuba's vertices (in order), triangles, texture coordinates and
    normals (Mitsuba stores float32: tolerances of a few float32 ulps)."""
    if flip_tex_coords is not None:
        parameters["flip_tex_coords"] = flip_tex_coords
    ours = meshes.load_mesh_file(Path(path), smooth, flip_tex_coords, parameters.get("shape_index", 0))
    positions, faces, uvs, normals = mitsuba_mesh(kind, path, face_normals=not smooth, **parameters)
    scale = max(1.0, float(np.abs(positions).max()))
    np.testing.assert_allclose(ours.vertices, positions, rtol=0, atol=1e-6 * scale)
    np.testing.assert_array_equal(ours.faces, faces)
    assert (ours.uvs is None) == (uvs is None)
    if uvs is not None:
        np.testing.assert_allclose(ours.uvs, uvs, rtol=0, atol=2e-7 * max(1.0, float(np.abs(uvs).max())))
    if smooth:
        np.testing.assert_allclose(ours.normals, normals, rtol=0, atol=2e-5)
    else:
        assert ours.normals is None and normals is None


# --------------------------------------------------------------------------------------------
# OBJ
# --------------------------------------------------------------------------------------------
OBJ = """# a quad and a triangle sharing positions with other texture coordinates and normals
v 0 0 0
v 1 0 0
v 1 1 0.25
v 0 1 0
v 9 9 9
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vt 0.5 0.25 0.0
vn 0 0 1
vn 0 0.6 0.8
vn 1 1 1
f 1/1/1 2/2/1 3/3/1 4/4/1
f 1/5/2 2/2/1 3/3/3
f 1/1/1 3/3/1 4/4/1
"""


def corners_as(text, fields):
    """`text` with every face corner p/t/n rewritten as p/t (fields "pt"), p//n ("pn") or p ("p")."""
    def corner(word):
        p, t, n = word.split("/")
        return {"pt": f"{p}/{t}", "pn": f"{p}//{n}", "p": p}[fields]
    return "".join(" ".join(["f"] + [corner(w) for w in line.split()[1:]]) + "\n" if line.startswith("f ") else line
                   for line in text.splitlines(True))


OBJ_VARIANTS = {
    "v/vt/vn": OBJ,
    "crlf": OBJ.replace("\n", "\r\n"),
    "groups": OBJ.replace("\nf 1/1/1", "\no part\ng side\nusemtl red\ns 1\nf 1/1/1").replace("v 0 0 0", "v 0 0 0 1"),
    "pentagon": OBJ.replace("f 1/1/1 2/2/1 3/3/1 4/4/1", "f 1/1/1 2/2/1 3/3/1 4/4/1 5/5/2"),
    # Without the lists faces do not use (Mitsuba leaves such values undefined).
    "v/vt": corners_as(OBJ, "pt").replace("vn ", "# vn "),      # no normals: computed
    "v//vn": corners_as(OBJ, "pn").replace("vt ", "# vt "),
    "v": corners_as(OBJ, "p").replace("vt ", "# vt ").replace("vn ", "# vn "),   # one vertex per position
}


@needs_mitsuba
@pytest.mark.parametrize("smooth", [True, False])
@pytest.mark.parametrize("flip_tex_coords", [None, True, False])
@pytest.mark.parametrize("variant", OBJ_VARIANTS)
def test_obj_files_load_as_mitsuba_loads_them(tmp_path, variant, flip_tex_coords, smooth):
    path = tmp_path / "mesh.obj"
    path.write_text(OBJ_VARIANTS[variant])
    assert_same_as_mitsuba(path, "obj", smooth, flip_tex_coords)


def test_obj_vertices_are_split_where_texture_coordinates_or_normals_differ(tmp_path):
    path = tmp_path / "mesh.obj"
    path.write_text(OBJ)
    mesh = meshes.load_mesh_file(path, smooth=True)
    # Five distinct (p, t, n) triples: position 1 twice (uv 1 and 5), position 3 twice (normal 1 and 3).
    assert len(mesh.vertices) == 6 and len(mesh.faces) == 4
    np.testing.assert_array_equal(mesh.faces[2], [4, 1, 5])
    np.testing.assert_array_equal(mesh.vertices[mesh.faces[2]], [[0, 0, 0], [1, 0, 0], [1, 1, 0.25]])
    np.testing.assert_allclose(mesh.uvs[mesh.faces[2]], [[0.5, 0.75], [1, 1], [1, 0]])   # v flipped
    np.testing.assert_allclose(mesh.normals[mesh.faces[2]], [[0, 0.6, 0.8], [0, 0, 1], [3 ** -0.5] * 3])
    assert not any(np.all(mesh.vertices[i] == [9, 9, 9]) for i in range(len(mesh.vertices)))   # unused: dropped


@needs_mitsuba
@pytest.mark.parametrize("path", real_files("bitterli-living-room/models/Mesh0[0-6][05].obj")
                         + real_files("tutorials-cbox/meshes/*.obj") + real_files("test-textured-principled/common/meshes/*.obj"))
def test_real_obj_files_load_as_mitsuba_loads_them(path):
    assert_same_as_mitsuba(path, "obj")


def test_obj_negative_indices_count_back_from_their_face(tmp_path):
    path = tmp_path / "relative.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf -3/-3 -2/-2 -1/-1\n"
                    "v 5 5 5\nvt 0.5 0.5\nf -4/-4 -3/-3 -1/-1\n")
    mesh = meshes.load_mesh_file(path, smooth=False, flip_tex_coords=False)
    np.testing.assert_array_equal(mesh.vertices[mesh.faces], [[[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                                                              [[0, 0, 0], [1, 0, 0], [5, 5, 5]]])
    np.testing.assert_array_equal(mesh.uvs[mesh.faces[1]], [[0, 0], [1, 0], [0.5, 0.5]])


def test_obj_files_give_trimeshs_triangles(tmp_path):
    """The triangles trimesh makes of the same file (corner positions, in order up to a cyclic
    turn: it splits quads along the same diagonal, starting elsewhere), a check independent of
    Mitsuba."""
    import trimesh

    def turned_to_first_corner(triangles):   # each triangle started at its smallest corner
        keys = [min(range(3), key=lambda k: tuple(t[k])) for t in triangles]
        return np.array([np.roll(t, -k, axis=0) for t, k in zip(triangles, keys)])

    path = tmp_path / "mesh.obj"
    path.write_text(OBJ_VARIANTS["pentagon"])
    theirs = trimesh.load(str(path), force="mesh", process=False)
    ours = meshes.load_mesh_file(path, smooth=False)
    np.testing.assert_array_equal(turned_to_first_corner(ours.vertices[ours.faces]),
                                  turned_to_first_corner(np.asarray(theirs.vertices)[np.asarray(theirs.faces)]))


def read_both_ways(text):
    """The statements of an OBJ text as the plain forms' reader reads them (None: not plain) and
    as the general reader does (a malformed text: ObjError)."""
    from clrender import obj_reader

    prepared = obj_reader._statement_text(text if isinstance(text, bytes) else text.encode())
    return obj_reader._plain_statements(prepared), lambda: obj_reader._general_statements(prepared)


def assert_read_alike(text):
    plain, general = read_both_ways(text)
    assert plain is not None
    general = general()
    for ours, theirs in zip(plain[:3] + list(plain[3]), general[:3] + general[3]):
        assert ours.dtype == theirs.dtype
        np.testing.assert_array_equal(ours, theirs)


PLAIN_OBJ = {**OBJ_VARIANTS, "pt vt-w": corners_as(OBJ, "pt").replace("vt 1 1", "vt 1 1 0.5"),
             "tabs and indents": "\tv 0\t0 0 \n  v 1  0 0\t\nv 0 1 0\nf\t1 2\t 3 \n",
             "signs and exponents": "v +1e-3 -.5 2.\nv 1E+2 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf +1/1 -2/-2 3/+3\n",
             "interleaved kinds": "v 0 0 0\nvn 0 0 1\nv 1 0 0\nvn 0 1 0\nvt 0.5 0.5\nv 0 1 0\nvn 1 0 0\ng x\n"
                                  "f 1/1/1 2/1/2 3/1/3\ns off\nf 3/1/3 2/1/2 1/1/1\n",
             "no final line break": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3"}
NOT_PLAIN_OBJ = {"comment after a statement": "v 0 0 0 # origin\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
                 "corners of several forms": "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3\n",
                 "p/ corner": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/ 2/ 3/\n",
                 "inf": "v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n",
                 "carriage return in a line": "v 0 0 0\nv 1\r0 0\nv 0 1 0\nf 1 2 3\n",
                 "two numbers glued": "v 0 0 0\nv 1.0.0 0 0\nv 0 1 0\nf 1 2 3\n",
                 "sign after an index": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3-\n",
                 "lone sign": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 + 3\n",
                 "four slashes": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2/1/1/1 3/1/1/1\n",
                 "too few numbers": "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
                 "too many normal numbers": "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1 0\nf 1//1 2//1 3//1\n",
                 "a face of two corners": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n"}


@pytest.mark.parametrize("name", PLAIN_OBJ)
def test_plain_obj_statements_read_as_the_general_reader_reads_them(name):
    assert_read_alike(PLAIN_OBJ[name])


@pytest.mark.parametrize("name", NOT_PLAIN_OBJ)
def test_obj_statements_of_other_forms_are_left_to_the_general_reader(name):
    assert read_both_ways(NOT_PLAIN_OBJ[name])[0] is None


@pytest.mark.parametrize("path", real_files("bitterli-living-room/models/Mesh0[0-6]*.obj")
                         + real_files("bitterli-staircase/models/Mesh0[0-3]*.obj"))
def test_real_obj_files_are_plain_and_read_as_the_general_reader_reads_them(path):
    assert_read_alike(Path(path).read_bytes())


@pytest.mark.parametrize("text, message", [
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n\nf 1 2 4\n", "line 6: face 'f 1 2 4' names a position beyond the 3"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", "line 4: face 'f 1 2 0' names index 0 (indices start at 1)"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/2 2/1 3/1\n", "line 5: face 'f 1/2 2/1 3/1' names a texture coordinate beyond the 1"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 2 3\n", "names a position beyond the 3 the file has before it"),
    ("v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", "line 2: cannot read 'v 1 0' (expected 3 numbers)"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.3\nf 1 2 3\n", "line 4: cannot read 'vt 0.3' (expected 2 numbers)"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "line 4: cannot read 'f 1 2' (expected 3 or more corners"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 x\nf 1 2 3\n", "line 3: cannot read 'v 0 1 x'"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 1e39\nf 1 2 3\n", "vertex 3 is not finite in float32"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 1e39\nf 1/1 2/1 3/1\n", "texture coordinate 1 is not finite in float32"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\n", "the file holds no faces"),
    ("this is not an obj file\n", "the file holds no faces"),
    ("v 0 0 0\0\n", "not a text file"),
])
def test_malformed_obj_files_are_errors_naming_the_file_and_line(tmp_path, text, message):
    (tmp_path / "bad.obj").write_text(text)
    data = {"camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
            "materials": [{"name": "white", "type": "diffuse"}],
            "shapes": [{"type": "mesh", "file": "bad.obj", "material": "white"}]}
    with pytest.raises(clrender.SceneError) as error:
        clrender.load_scene_dict(data, base_dir=tmp_path)
    assert str(error.value).startswith(f"shapes[0].file: cannot load mesh {tmp_path / 'bad.obj'}: ")
    assert message in str(error.value)


# --------------------------------------------------------------------------------------------
# PLY
# --------------------------------------------------------------------------------------------
def ply_vertex(uv_names=("u", "v"), normals=True, position_type="float"):
    rng = np.random.default_rng(7)
    vertex = {name: (position_type, rng.normal(size=6)) for name in "xyz"}
    if normals:
        vertex.update({name: ("float", rng.normal(size=6)) for name in ("nx", "ny", "nz")})
    if uv_names:
        vertex.update({name: ("float", rng.random(6)) for name in uv_names})
    vertex["confidence"] = ("uchar", np.arange(6))   # a property readers skip
    return vertex


PLY_FACES = [[0, 1, 2], [2, 1, 3], [3, 4, 5], [5, 0, 3]]


@needs_mitsuba
@pytest.mark.parametrize("encoding", ["ascii", "binary_little_endian", "binary_big_endian"])
@pytest.mark.parametrize("uv_names", [("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t"), None])
@pytest.mark.parametrize("normals", [True, False])
def test_ply_files_load_as_mitsuba_loads_them(tmp_path, encoding, uv_names, normals):
    path = tmp_path / "mesh.ply"
    # Mitsuba 3.9 misreads files with another element, with a list property, before the vertices:
    # test_ply_elements_are_skipped checks that case.
    write_ply_file(path, encoding, ply_vertex(uv_names, normals, "double" if normals else "float"), PLY_FACES,
                   index_type="uint" if normals else "int")
    for smooth in (True, False):
        for flip in (None, True, False):
            assert_same_as_mitsuba(path, "ply", smooth, flip)


@needs_mitsuba
@pytest.mark.parametrize("path", real_files("tutorials-simple-teapot/meshes/*.ply") + real_files("docs-medium-sss-bunny/common/meshes/*.ply"))
def test_real_ply_files_load_as_mitsuba_loads_them(path):
    assert_same_as_mitsuba(path, "ply")


@pytest.mark.parametrize("encoding", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_elements_are_skipped(tmp_path, encoding):
    """Other elements (here one with a list property, before the vertices) and properties do
    not change the mesh."""
    write_ply_file(tmp_path / "plain.ply", encoding, ply_vertex(), PLY_FACES)
    write_ply_file(tmp_path / "extra.ply", encoding, ply_vertex(), PLY_FACES, extra_element=True)
    plain, extra = (meshes.load_mesh_file(tmp_path / name, smooth=True) for name in ("plain.ply", "extra.ply"))
    for field in ("vertices", "faces", "normals", "uvs"):
        np.testing.assert_array_equal(getattr(plain, field), getattr(extra, field))
    np.testing.assert_allclose(plain.vertices, np.stack([ply_vertex()[name][1] for name in "xyz"], axis=1), atol=1e-6)


@pytest.mark.parametrize("encoding", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_polygons_become_fans(tmp_path, encoding):
    """Mitsuba takes triangles only; clrender reads polygons as fans, whatever mix of sizes."""
    path = tmp_path / "polygons.ply"
    write_ply_file(path, encoding, ply_vertex(), [[0, 1, 2, 3], [3, 4, 5], [5, 4, 2, 1, 0]], count_type="uchar")
    mesh = meshes.load_mesh_file(path, smooth=False)
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2], [0, 2, 3], [3, 4, 5], [5, 4, 2], [5, 2, 1], [5, 1, 0]])


def test_exported_ply_files_keep_texture_coordinates(tmp_path):
    rng = np.random.default_rng(3)
    vertices, uvs, faces = rng.normal(size=(5, 3)), rng.random((5, 2)), np.array([[0, 1, 2], [2, 3, 4]])
    write_ply(tmp_path / "mesh.ply", vertices, faces, uvs=uvs)
    mesh = meshes.load_mesh_file(tmp_path / "mesh.ply", smooth=False)
    np.testing.assert_allclose(mesh.uvs, uvs, atol=1e-7)   # PLY: not flipped, as in Mitsuba
    np.testing.assert_array_equal(mesh.faces, faces)


# --------------------------------------------------------------------------------------------
# Mitsuba serialized
# --------------------------------------------------------------------------------------------
def serialized_shapes():
    rng = np.random.default_rng(5)
    positions, normals, uvs = rng.normal(size=(6, 3)), rng.normal(size=(6, 3)), rng.random((6, 2))
    faces = [[0, 1, 2], [3, 4, 5], [0, 2, 4]]
    return [dict(positions=positions, faces=faces, normals=normals, uvs=uvs, colors=rng.random((6, 3)), name="first"),
            dict(positions=2 * positions, faces=faces, uvs=uvs, double=True, name="second"),
            dict(positions=3 * positions, faces=faces, normals=normals, face_normals=True)]


@needs_mitsuba
@pytest.mark.parametrize("version", [3, 4])
def test_serialized_files_load_as_mitsuba_loads_them(tmp_path, version):
    path = tmp_path / "meshes.serialized"
    write_serialized(path, serialized_shapes(), version)
    for index in range(3):
        for smooth in (True, False):
            assert_same_as_mitsuba(path, "serialized", smooth, shape_index=index)


@needs_mitsuba
@pytest.mark.parametrize("path", real_files("ppg-torus/meshes.serialized") + real_files("mitsuba-matpreview/*.serialized")
                         + real_files("docs-medium-sss-bunny/common/meshes/*.serialized"))
def test_real_serialized_files_load_as_mitsuba_loads_them(path):
    from clrender.serialized import shape_count

    for index in range(shape_count(path)):
        assert_same_as_mitsuba(path, "serialized", shape_index=index)


def test_serialized_texture_coordinates_are_as_stored(tmp_path):
    path = tmp_path / "meshes.serialized"
    shapes = serialized_shapes()
    write_serialized(path, shapes)
    np.testing.assert_allclose(meshes.load_mesh_file(path, False).uvs, shapes[0]["uvs"], atol=1e-7)
    flipped = meshes.load_mesh_file(path, False, flip_tex_coords=True).uvs
    np.testing.assert_allclose(flipped, shapes[0]["uvs"] * [1, -1] + [0, 1], atol=1e-7)


def scene_with_mesh(**shape):
    return {"camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
            "materials": [{"name": "white", "type": "diffuse"}],
            "shapes": [{"type": "mesh", "material": "white", **shape}]}


def mesh_error(tmp_path, **shape):
    with pytest.raises(clrender.SceneError) as error:
        clrender.load_scene_dict(scene_with_mesh(**shape), base_dir=tmp_path)
    return str(error.value)


def test_serialized_shape_index_picks_the_shape(tmp_path):
    write_serialized(tmp_path / "m.serialized", serialized_shapes())
    scene = clrender.load_scene_dict(scene_with_mesh(file="m.serialized", shape_index=1), base_dir=tmp_path)
    np.testing.assert_allclose(scene.shapes[0].mesh.vertices, 2 * serialized_shapes()[0]["positions"])
    text = mesh_error(tmp_path, file="m.serialized", shape_index=3)
    assert "shape_index 3 is out of range: the file has 3 shapes (0..2)" in text and "m.serialized" in text
    assert mesh_error(tmp_path, file="m.serialized", shape_index=-1).startswith("shapes[0].shape_index: must be >= 0")
    (tmp_path / "m.obj").write_text(OBJ)
    assert mesh_error(tmp_path, file="m.obj", shape_index=0) == "shapes[0].shape_index: unknown field"


def hostile_serialized(tmp_path, change):
    """A serialized file of the test shapes damaged by `change(bytes) -> bytes`."""
    path = tmp_path / "hostile.serialized"
    write_serialized(path, serialized_shapes(), version=3)
    path.write_bytes(change(path.read_bytes()))
    return path


def huge_counts(data):
    """The first shape claiming 2^40 vertices and triangles (its stream re-compressed)."""
    body = bytearray(zlib.decompressobj().decompress(data[4:]))
    body[4:20] = struct.pack("<QQ", 1 << 40, 1 << 26)   # after the flags (version 3: no name)
    return data[:4] + zlib.compress(bytes(body)) + data[-16:]


@pytest.mark.parametrize("change, shape_index, message", [
    (lambda d: d[:len(d) // 3], 0, "the shape's data ends early"),
    (lambda d: d[:60], 0, "the shape's data ends early"),
    (lambda d: d[:2], 0, "not a Mitsuba serialized mesh"),
    (lambda d: d[:40] + bytes(b ^ 0x5A for b in d[40:80]) + d[80:], 0, "corrupt compressed data"),
    (lambda d: b"\x1c\x04\x05\x00" + d[4:], 0, "unsupported serialized format version 5"),
    (lambda d: b"PK" + d[2:], 0, "not a Mitsuba serialized mesh (bad format tag)"),
    (lambda d: d[:-4] + struct.pack("<I", 1 << 30), 1, "the end-of-file dictionary lists 1073741824 shapes"),
    (lambda d: d[:-8] + struct.pack("<I", 1 << 31) + d[-4:], 2, "a shape offset (2147483648) lies outside the file"),
    (lambda d: d[:-8] + struct.pack("<I", 7) + d[-4:], 2, "no shape at offset 7 (bad format tag)"),
    (lambda d: d, 9, "shape_index 9 is out of range"),
    (huge_counts, 0, "more than its"),
], ids=["truncated", "truncated-header", "tiny", "corrupt-zlib", "version", "tag", "dictionary", "offset",
        "offset-into-data", "index", "huge-counts"])
def test_hostile_serialized_files_are_clean_errors_in_bounded_memory(tmp_path, change, shape_index, message):
    path = hostile_serialized(tmp_path, change)
    tracemalloc.start()
    try:
        text = mesh_error(tmp_path, file=path.name, shape_index=shape_index)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert text.startswith(f"shapes[0].file: cannot load mesh {path}: ") and message in text, text
    assert peak < 8 * 2**20


@pytest.mark.parametrize("change, message", [
    (lambda d: d.replace(b"element vertex 6", b"element vertex 99999999999"), "element 'vertex' has 99999999999 rows, more than"),
    (lambda d: d.replace(b"element face 4", b"element face 4000000000"), "element 'face' has 4000000000 rows, more than"),
    (lambda d: d[:-7], "the file ends inside its data"),
    (lambda d: d.replace(b"format binary_little_endian", b"format binary_middle_endian"), "header line 2"),
    (lambda d: d.replace(b"end_header", b"end_headed"), "not a PLY file"),
    (lambda d: d.replace(b"property float x", b"property float w"), "the vertex element has no x"),
    (lambda d: d.replace(b"vertex_indices", b"corners"), "the face element has no list 'vertex_indices'"),
    (lambda d: d.replace(b"property list uchar int", b"property list uchar quad"), "header line"),
], ids=["huge-vertices", "huge-faces", "truncated", "format", "header", "no-x", "no-indices", "type"])
def test_hostile_ply_files_are_clean_errors_in_bounded_memory(tmp_path, change, message):
    path = tmp_path / "hostile.ply"
    write_ply_file(path, "binary_little_endian", ply_vertex(), PLY_FACES)
    path.write_bytes(change(path.read_bytes()))
    tracemalloc.start()
    try:
        text = mesh_error(tmp_path, file=path.name)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert text.startswith(f"shapes[0].file: cannot load mesh {path}: ") and message in text, text
    assert peak < 8 * 2**20


@pytest.mark.parametrize("faces, message", [
    ([[0, 1, 9]], "a face names a vertex that does not exist (the file has 6)"),
    ([[0, 1]], "face 0 has 2 vertices"),
])
@pytest.mark.parametrize("encoding", ["ascii", "binary_big_endian"])
def test_ply_faces_must_name_existing_vertices(tmp_path, encoding, faces, message):
    write_ply_file(tmp_path / "bad.ply", encoding, ply_vertex(), faces)
    assert message in mesh_error(tmp_path, file="bad.ply")


# --------------------------------------------------------------------------------------------
# Mitsuba XML scenes
# --------------------------------------------------------------------------------------------
XML_SHAPES = [
    '<shape type="obj"><string name="filename" value="m.obj"/><boolean name="flip_tex_coords" value="false"/>'
    '<transform name="to_world"><rotate y="1" angle="30"/><scale x="2"/></transform></shape>',
    '<shape type="ply"><string name="filename" value="m.ply"/><boolean name="flip_tex_coords" value="true"/>'
    '<boolean name="face_normals" value="true"/></shape>',
    '<shape type="serialized"><string name="filename" value="m.serialized"/><integer name="shape_index" value="1"/>'
    '<transform name="to_world"><translate x="1" y="2" z="3"/><scale value="0.5"/></transform></shape>',
]


@needs_mitsuba
@pytest.mark.parametrize("shape", XML_SHAPES, ids=["obj", "ply", "serialized"])
def test_xml_mesh_shapes_load_as_mitsuba_loads_them(tmp_path, shape):
    """World-space vertices, texture coordinates and normals of obj, ply and serialized shapes
    with their options and to_world, from the same XML file."""
    (tmp_path / "m.obj").write_text(OBJ)
    write_ply_file(tmp_path / "m.ply", "binary_little_endian", ply_vertex(), PLY_FACES)
    write_serialized(tmp_path / "m.serialized", serialized_shapes())
    path = tmp_path / "scene.xml"
    sensor = ('<sensor type="perspective"><transform name="to_world"><lookat origin="0, 0, 9" target="0, 0, 0"/>'
              '</transform></sensor>')
    path.write_text(f'<scene version="3.0.0">{sensor}{shape}</scene>')
    mi.set_variant("scalar_rgb")
    theirs = mi.traverse(mi.load_file(str(path)).shapes()[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", clrender.MitsubaXmlWarning)   # no film
        ours = clrender.load_scene(path).shapes[0].mesh
    np.testing.assert_allclose(ours.vertices, np.array(theirs["vertex_positions"]).reshape(-1, 3), atol=1e-5)
    np.testing.assert_array_equal(ours.faces, np.array(theirs["faces"]).reshape(-1, 3))
    np.testing.assert_allclose(ours.uvs, np.array(theirs["vertex_texcoords"]).reshape(-1, 2), atol=1e-6)
    normals = np.array(theirs["vertex_normals"]).reshape(-1, 3)
    assert (ours.normals is None) == (normals.size == 0)
    if ours.normals is not None:
        np.testing.assert_allclose(ours.normals, normals, atol=2e-5)


# --------------------------------------------------------------------------------------------
# The scene format
# --------------------------------------------------------------------------------------------
def test_flip_tex_coords_defaults_to_mitsubas_choice_per_format(tmp_path):
    (tmp_path / "m.obj").write_text(OBJ)
    write_ply_file(tmp_path / "m.ply", "ascii", ply_vertex(), PLY_FACES)
    for name, flipped in (("m.obj", True), ("m.ply", False)):
        raw = meshes.load_mesh_file(tmp_path / name, False, flip_tex_coords=False).uvs
        for given, expect in ((None, flipped), (True, True), (False, False)):
            shape = {"file": name} if given is None else {"file": name, "flip_tex_coords": given}
            uvs = clrender.load_scene_dict(scene_with_mesh(**shape), base_dir=tmp_path).shapes[0].mesh.uvs
            expected = raw * [1, -1] + [0, 1] if expect else raw
            np.testing.assert_array_equal(uvs, expected.astype(np.float32))   # as a scene keeps them
    assert mesh_error(tmp_path, file="m.obj", flip_tex_coords=1) == "shapes[0].flip_tex_coords: must be true or false, got 1"


def test_smooth_meshes_take_the_files_normals(tmp_path):
    (tmp_path / "m.obj").write_text(OBJ.replace("vn 1 1 1", "vn 0 0 0"))   # no direction: computed instead
    mesh = clrender.load_scene_dict(scene_with_mesh(file="m.obj", smooth=True), base_dir=tmp_path).shapes[0].mesh
    computed = meshes.vertex_normals(mesh.vertices, mesh.faces)
    from_file = np.array([np.allclose(n, [0, 0, 1]) or np.allclose(n, [0, 0.6, 0.8]) for n in mesh.normals])
    assert from_file.sum() == len(mesh.normals) - 1
    np.testing.assert_allclose(mesh.normals[~from_file], computed[~from_file])
