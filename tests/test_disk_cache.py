"""Arrays cached on disk between processes (clrender/disk_cache.py): a stored entry gives back the
array stored, a damaged one is computed again, and the device-computed tables, OBJ meshes and
wide BVHs read from the cache are bit-identical to the ones computed (and the device, the
parser or the builder is not asked again)."""
import hashlib

import numpy as np
import pytest

import clrender
from clrender import arrays, disk_cache, energy, meshes, obj_reader, plastic, ploc, shapes_cache
from clrender.arrays import build_scene_arrays
from clrender.energy import fill_albedo_tables
from clrender.files import file_identity, recording_inputs
from conftest import camera


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("CLRENDER_CACHE_DIR", str(tmp_path))
    return tmp_path


def test_an_entry_gives_back_its_array(cache):
    array = np.arange(24, dtype=np.float32).reshape(2, 3, 4) / 7
    disk_cache.store("maps", "k", array)
    loaded = disk_cache.load("maps", "k", (2, 3, 4))
    assert loaded.dtype == np.float32 and np.array_equal(loaded, array)
    assert disk_cache.load("maps", "other", (2, 3, 4)) is None
    assert disk_cache.load("maps", "k", (2, 3, 5)) is None   # another size: not this entry


@pytest.mark.parametrize("damage", ["truncate", "flip", "extend", "magic"])
def test_a_damaged_entry_is_not_used(cache, damage):
    array = np.linspace(0, 1, 64, dtype=np.float32)
    disk_cache.store("maps", "k", array)
    path, = (cache / "maps").iterdir()
    data = bytearray(path.read_bytes())
    if damage == "truncate":
        data = data[:-1]
    elif damage == "flip":
        data[-5] ^= 1
    elif damage == "extend":
        data += b"\0"
    else:
        data[0] ^= 1
    path.write_bytes(bytes(data))
    assert disk_cache.load("maps", "k", (64,)) is None


def test_named_arrays_come_back_with_their_types_shapes_and_nones(cache):
    stored = {"positions": np.arange(12, dtype=np.float64).reshape(4, 3) / 3, "uvs": None,
              "faces": np.arange(6, dtype=np.int64).reshape(2, 3), "empty": np.zeros((0, 2), np.int32)}
    disk_cache.store_arrays("meshes", "k", stored)
    loaded = disk_cache.load_arrays("meshes", "k")
    assert list(loaded) == list(stored) and loaded["uvs"] is None
    for name in ("positions", "faces", "empty"):
        assert loaded[name].dtype == stored[name].dtype and np.array_equal(loaded[name], stored[name])
        assert loaded[name].shape == stored[name].shape
    assert disk_cache.load_arrays("meshes", "other") is None


@pytest.mark.parametrize("damage", ["truncate", "flip", "extend", "magic"])
def test_a_damaged_entry_of_named_arrays_is_not_used(cache, damage):
    disk_cache.store_arrays("meshes", "k", {"a": np.linspace(0, 1, 64), "b": None})
    path, = (cache / "meshes").iterdir()
    data = bytearray(path.read_bytes())
    if damage == "truncate":
        data = data[:-1]
    elif damage == "flip":
        data[len(data) // 2] ^= 1
    elif damage == "extend":
        data += b"\0"
    else:
        data[0] ^= 1
    path.write_bytes(bytes(data))
    assert disk_cache.load_arrays("meshes", "k") is None


@pytest.mark.parametrize("header", [b"not json", b'[["a", "<f8", [1000]]]', b'[["a", "no type", [2]]]', b"[1]"])
def test_an_entry_whose_header_does_not_describe_its_bytes_is_not_used(cache, header):
    # Checksummed as a whole, but written by other code: its header names arrays its bytes do
    # not hold, or is no header at all.
    payload = len(header).to_bytes(8, "little") + header + np.zeros(2).tobytes()
    path = cache / "meshes" / "k.bin"
    path.parent.mkdir()
    path.write_bytes(disk_cache._MAGIC + hashlib.sha256(payload).digest() + payload)
    assert disk_cache.load_arrays("meshes", "k") is None


OBJ = b"""v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1
vn 0 0 1\nf 1/1/1 2/2/1 3/3/1 4/4/1\n"""


def parse_counting(monkeypatch):
    calls = []
    parse = obj_reader.parse_obj
    monkeypatch.setattr(obj_reader, "parse_obj", lambda text: calls.append(text) or parse(text))
    return calls


def test_an_obj_file_is_parsed_once_per_content(cache, tmp_path, monkeypatch):
    path = tmp_path / "quad.obj"
    path.write_bytes(OBJ)
    calls = parse_counting(monkeypatch)
    first, again = obj_reader.read_obj(path), obj_reader.read_obj(path)
    assert len(calls) == 1
    for name in ("positions", "faces", "uvs", "normals"):
        a, b = getattr(first, name), getattr(again, name)
        assert a.dtype == b.dtype and np.array_equal(a, b)
    path.write_bytes(OBJ.replace(b"v 1 1 0", b"v 1 2 0"))   # other bytes: parsed again
    changed = obj_reader.read_obj(path)
    assert len(calls) == 2 and changed.positions[2, 1] == 2
    # A whole scene from the cached mesh renders as from the parsed one.
    scene = {"camera": camera(), "materials": [{"name": "white", "type": "diffuse", "albedo": [0.8, 0.8, 0.8]}],
             "shapes": [{"type": "mesh", "file": str(path), "material": "white"}]}
    assert clrender.load_scene_dict(scene).shapes[0].mesh.vertices[2, 1] == 2


def test_a_malformed_obj_file_is_an_error_every_time(cache, tmp_path, monkeypatch):
    path = tmp_path / "bad.obj"
    path.write_bytes(b"v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    calls = parse_counting(monkeypatch)
    for _ in range(2):
        with pytest.raises(obj_reader.ObjError, match="line 3"):
            obj_reader.read_obj(path)
    assert len(calls) == 2 and not (cache / "meshes").exists()


def test_a_wide_bvh_is_built_once_per_geometry(cache, monkeypatch):
    rng = np.random.default_rng(3)
    v0 = rng.uniform(-1, 1, (500, 3))
    v1, v2 = v0 + rng.uniform(-0.1, 0.1, (500, 3)), v0 + rng.uniform(-0.1, 0.1, (500, 3))
    centres, radii = rng.uniform(-1, 1, (3, 3)), rng.uniform(0.05, 0.2, 3)
    builds = []
    build = ploc.build_ploc_bvh
    monkeypatch.setattr(ploc, "build_ploc_bvh", lambda *a, **k: builds.append(1) or build(*a, **k))
    nodes, depth, order = arrays.wide_bvh_of(v0, v1, v2, centres, radii)
    cached_nodes, cached_depth, cached_order = arrays.wide_bvh_of(v0, v1, v2, centres, radii)
    assert len(builds) == 1
    assert cached_nodes.dtype == nodes.dtype and cached_nodes.tobytes() == nodes.tobytes()
    assert cached_depth == depth and cached_order.dtype == order.dtype and np.array_equal(cached_order, order)
    arrays.wide_bvh_of(v0, v1, v2 + 1e-3, centres, radii)   # other geometry: built
    arrays.wide_bvh_of(v0, v1, v2, centres, radii * 2)
    assert len(builds) == 3


def test_an_unwritable_cache_only_costs_the_computation(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("CLRENDER_CACHE_DIR", str(blocker))   # a file: no folder can be made in it
    disk_cache.store("maps", "k", np.zeros(3, np.float32))
    assert disk_cache.load("maps", "k", (3,)) is None


def test_a_write_that_fails_midway_leaves_no_file(cache, monkeypatch):
    # A full disk: the entry's bytes cannot all be written.
    class FullDisk:
        def __init__(self, fd, mode):
            self.file = open(fd, mode)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.file.close()

        def write(self, data):
            self.file.write(data[:1])
            raise OSError(28, "No space left on device")

    monkeypatch.setattr(disk_cache.os, "fdopen", FullDisk)
    disk_cache.store_arrays("meshes", "k", {"a": np.zeros(1000)})
    assert list((cache / "meshes").iterdir()) == []
    assert disk_cache.load_arrays("meshes", "k") is None


def test_obj_files_read_through_an_unwritable_cache(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("CLRENDER_CACHE_DIR", str(blocker))
    path = tmp_path / "quad.obj"
    path.write_bytes(OBJ)
    assert len(obj_reader.read_obj(path).faces) == len(obj_reader.read_obj(path).faces) == 2


# Materials with tables: a plastic's rough coat (plastic.py) and the energy tables of a rough
# dielectric and a rough conductor (energy.py).
TABLE_MATERIALS = [
    {"name": "coat", "type": "plastic", "diffuse": [0.5, 0.5, 0.5], "roughness": 0.4, "ior": 1.6},
    {"name": "glass", "type": "dielectric", "ior": 1.45, "roughness": 0.3},
    {"name": "metal", "type": "conductor", "tint": [0.9, 0.8, 0.7], "roughness": 0.5, "material": "Au"},
]


def table_arrays():
    scene = clrender.load_scene_dict({
        "camera": camera(), "materials": TABLE_MATERIALS,
        "shapes": [{"type": "rectangle", "material": m["name"]} for m in TABLE_MATERIALS]})
    return build_scene_arrays(scene)


def filled_tables(queue):
    arrays = table_arrays()
    fill_albedo_tables(queue, arrays)
    return arrays.specular_albedo


def test_tables_read_from_disk_are_the_computed_ones(cache, queue, monkeypatch):
    monkeypatch.setattr(plastic, "_cache", {})
    monkeypatch.setattr(energy, "_cache", {})
    computed = filled_tables(queue)
    assert len(list((cache / "tables").iterdir())) == len(TABLE_MATERIALS)
    # A new process: nothing in memory; the tables' program must not even be built.
    monkeypatch.setattr(plastic, "_cache", {})
    monkeypatch.setattr(energy, "_cache", {})
    monkeypatch.setattr(energy, "build_program", lambda *a, **k: pytest.fail("the tables' program was built"))
    stored = filled_tables(queue)
    assert np.isfinite(computed).all() and computed.any()
    assert np.array_equal(stored, computed)


def many_shapes_scene(folder, count=shapes_cache.MIN_SHAPES):
    """A scene of `count` shapes: OBJ files (a textured quad, smooth or not, moved), a sphere."""
    (folder / "quad.obj").write_bytes(OBJ)
    (folder / "other.obj").write_bytes(OBJ.replace(b"v 1 1 0", b"v 1 1 0.5"))
    shapes = [{"type": "sphere", "center": [0, 0, -3], "radius": 0.5, "material": "white", "name": "ball"}]
    for i in range(count - 1):
        shapes.append({"type": "mesh", "file": "quad.obj" if i % 2 else "other.obj", "smooth": i % 3 == 0,
                       "material": "white", "transform": {"translate": [0.1 * i, 0, 0], "rotate": [0, 7 * i, 0]}})
    return {"camera": camera(), "materials": [{"name": "white", "type": "diffuse", "albedo": [0.8, 0.8, 0.8]}],
            "shapes": shapes}


def mesh_reads_counting(monkeypatch):
    calls = []
    read = meshes.load_mesh_file
    monkeypatch.setattr(meshes, "load_mesh_file", lambda *a, **k: calls.append(a) or read(*a, **k))
    return calls


def assert_same_shapes(first, again):
    assert len(first) == len(again)
    for a, b in zip(first, again):
        assert (a.name, a.material, a.interior, a.exterior) == (b.name, b.material, b.interior, b.exterior)
        assert type(a.mesh) is type(b.mesh)
        for name, x in vars(a.mesh).items():
            y = getattr(b.mesh, name)
            if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
                assert x.dtype == y.dtype and np.array_equal(x, y), name
            else:
                assert x == y, name


def test_the_shapes_of_a_scene_of_many_are_read_once_per_content(cache, tmp_path, monkeypatch):
    data = many_shapes_scene(tmp_path)
    calls = mesh_reads_counting(monkeypatch)
    first = clrender.load_scene_dict(data, tmp_path).shapes
    assert len(calls) == len(first) - 1 and len(list((cache / "shapes").iterdir())) == 1
    again = clrender.load_scene_dict(data, tmp_path).shapes
    assert len(calls) == len(first) - 1   # one entry read instead
    assert_same_shapes(first, again)
    # Another file's bytes, another description, another material list: each is read again.
    (tmp_path / "quad.obj").write_bytes(OBJ.replace(b"v 1 1 0", b"v 1 3 0"))
    changed = clrender.load_scene_dict(data, tmp_path).shapes
    assert len(calls) == 2 * (len(first) - 1) and changed[2].mesh.vertices[:, 1].max() > 2.9
    data["shapes"][0]["radius"] = 0.25
    assert clrender.load_scene_dict(data, tmp_path).shapes[0].mesh.radius == 0.25
    data["materials"].insert(0, {"name": "black", "type": "diffuse", "albedo": [0, 0, 0]})
    assert all(s.material == 1 for s in clrender.load_scene_dict(data, tmp_path).shapes)
    assert len(calls) == 4 * (len(first) - 1)


@pytest.mark.parametrize("damage", ["truncate", "flip"])
def test_a_damaged_shapes_entry_is_read_again(cache, tmp_path, monkeypatch, damage):
    data = many_shapes_scene(tmp_path)
    first = clrender.load_scene_dict(data, tmp_path).shapes
    entry = next((cache / "shapes").iterdir())
    raw = bytearray(entry.read_bytes())
    if damage == "truncate":
        raw = raw[:len(raw) // 2]
    else:
        raw[-5] ^= 0x10
    entry.write_bytes(bytes(raw))
    calls = mesh_reads_counting(monkeypatch)
    assert_same_shapes(first, clrender.load_scene_dict(data, tmp_path).shapes)
    assert len(calls) == len(first) - 1


def test_few_shapes_or_a_bad_file_are_read_shape_by_shape(cache, tmp_path):
    data = many_shapes_scene(tmp_path, count=shapes_cache.MIN_SHAPES - 1)
    clrender.load_scene_dict(data, tmp_path)
    assert not (cache / "shapes").exists()
    data = many_shapes_scene(tmp_path)
    clrender.load_scene_dict(data, tmp_path)   # an entry for the scene as it was
    data["shapes"][5]["file"] = "missing.obj"
    with pytest.raises(clrender.SceneError, match=r"shapes\[5\]\.file.*not found"):
        clrender.load_scene_dict(data, tmp_path)
    data["shapes"][5]["file"] = str(tmp_path)   # a folder
    with pytest.raises(clrender.SceneError, match=r"shapes\[5\]\.file"):
        clrender.load_scene_dict(data, tmp_path)
    data["shapes"][5]["file"] = 7
    with pytest.raises(clrender.SceneError, match=r"shapes\[5\]\.file.*must be a string"):
        clrender.load_scene_dict(data, tmp_path)


def test_a_scene_read_from_the_entry_still_names_its_mesh_files_among_its_inputs(cache, tmp_path):
    """The CLI refuses an output that would replace a file the scene reads (files.recording_inputs)."""
    data = many_shapes_scene(tmp_path)
    for _ in range(2):   # shape by shape, then from the entry
        with recording_inputs() as inputs:
            clrender.load_scene_dict(data, tmp_path)
        assert {file_identity(tmp_path / "quad.obj"), file_identity(tmp_path / "other.obj")} <= inputs
    assert (cache / "shapes").exists()


def test_environment_tables_read_from_disk_are_the_computed_ones(cache, monkeypatch):
    image = np.random.default_rng(5).random((32, 128, 3)).astype(np.float32)
    tabulate = arrays._environment_tables
    calls = []
    monkeypatch.setattr(arrays, "_environment_tables", lambda *a: calls.append(a) or tabulate(*a))
    tables = {}
    for lookup in ("texel", "mitsuba"):
        tables[lookup] = arrays._stored_environment_tables(image, lookup)
        stored = arrays._stored_environment_tables(image, lookup)
        assert len(calls) == len(tables)   # the second read from disk
        for a, b in zip(tables[lookup], stored):
            assert np.array_equal(a, b) and np.asarray(a).dtype == np.asarray(b).dtype
    # Another image, or another sampling grid (a constant the key names besides the code): tabulated.
    other = image.copy()
    other[3, 5] += 1
    assert not np.array_equal(arrays._stored_environment_tables(other, "texel")[1], tables["texel"][1])
    monkeypatch.setattr(arrays, "ENV_SAMPLING_COLUMNS", 32)
    coarse = arrays._stored_environment_tables(image, "texel")
    assert len(calls) == 4 and np.array_equal(coarse[1], tabulate(image, "texel")[1])
    assert coarse[1].size < tables["texel"][1].size


def test_a_description_too_deep_to_key_is_read_shape_by_shape(cache, tmp_path):
    data = many_shapes_scene(tmp_path)
    deep = nested = []
    for _ in range(5000):   # beyond the JSON encoder's recursion, not the scene reader's
        nested.append([])
        nested = nested[0]
    data["shapes"][3]["extra"] = deep
    with pytest.raises(clrender.SceneError, match=r"shapes\[3\]\.extra"):
        clrender.load_scene_dict(data, tmp_path)


def test_the_shapes_of_large_mesh_files_are_read_shape_by_shape(cache, tmp_path, monkeypatch):
    data = many_shapes_scene(tmp_path)
    monkeypatch.setattr(shapes_cache, "MAX_FILE_BYTES", (shapes_cache.MIN_SHAPES - 1) * len(OBJ) - 1)
    calls = mesh_reads_counting(monkeypatch)
    for _ in range(2):
        clrender.load_scene_dict(data, tmp_path)
    assert len(calls) == 2 * (shapes_cache.MIN_SHAPES - 1) and not (cache / "shapes").exists()
