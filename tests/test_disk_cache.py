"""Arrays cached on disk between processes (clrender/disk_cache.py): a stored entry gives back the
array stored, a damaged one is computed again, and the device-computed tables read from the cache
are bit-identical to the ones computed (and the device is not asked again)."""
import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender import disk_cache, energy, plastic
from clrender.arrays import build_scene_arrays
from clrender.energy import fill_albedo_tables
from conftest import build_test_kernels, camera


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


def test_an_unwritable_cache_only_costs_the_computation(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("CLRENDER_CACHE_DIR", str(blocker))   # a file: no folder can be made in it
    disk_cache.store("maps", "k", np.zeros(3, np.float32))
    assert disk_cache.load("maps", "k", (3,)) is None


# Materials with tables: a plastic's rough coat (plastic.py) and the energy tables of a rough
# dielectric and a rough conductor (energy.py).
TABLE_MATERIALS = [
    {"name": "coat", "type": "plastic", "diffuse": [0.5, 0.5, 0.5], "roughness": 0.4, "ior": 1.6},
    {"name": "glass", "type": "dielectric", "ior": 1.45, "roughness": 0.3},
    {"name": "metal", "type": "conductor", "tint": [0.9, 0.8, 0.7], "roughness": 0.5, "material": "Au"},
]


@pytest.fixture(scope="module")
def kernels(context):
    return build_test_kernels(context, DIELECTRIC=1)


def table_arrays():
    scene = clrender.load_scene_dict({
        "camera": camera(), "materials": TABLE_MATERIALS,
        "shapes": [{"type": "rectangle", "material": m["name"]} for m in TABLE_MATERIALS]})
    return build_scene_arrays(scene)


def filled_tables(queue, program):
    arrays = table_arrays()
    fill_albedo_tables(queue, program, arrays)
    return arrays.specular_albedo


def test_tables_read_from_disk_are_the_computed_ones(cache, queue, kernels, monkeypatch):
    monkeypatch.setattr(plastic, "_cache", {})
    monkeypatch.setattr(energy, "_cache", {})
    computed = filled_tables(queue, kernels)
    assert len(list((cache / "tables").iterdir())) == len(TABLE_MATERIALS)
    # A new process: nothing in memory; the device must not be asked.
    monkeypatch.setattr(plastic, "_cache", {})
    monkeypatch.setattr(energy, "_cache", {})
    monkeypatch.setattr(cl, "Kernel", lambda *a: pytest.fail("a table was computed again"))
    stored = filled_tables(queue, kernels)
    assert np.isfinite(computed).all() and computed.any()
    assert np.array_equal(stored, computed)


def test_tables_of_a_program_without_a_build_key_stay_off_disk(cache, queue, kernels, monkeypatch):
    monkeypatch.setattr(plastic, "_cache", {})
    monkeypatch.setattr(energy, "_cache", {})
    monkeypatch.setattr(plastic, "program_key", lambda program: None)
    monkeypatch.setattr(energy, "program_key", lambda program: None)
    filled_tables(queue, kernels)
    assert not (cache / "tables").exists()
