"""Scene arrays a CPU device reads in place (clrender/host_memory.py, Renderer._upload): allocated
on page boundaries (kernels use aligned vector loads on buffers), passed without a copy, and the
renders the same as from copies."""
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender import host_memory, layout
from conftest import TEST_DEVICE


@pytest.mark.parametrize("dtype", [np.uint8, np.float32, layout.SPHERE, layout.WIDE_BVH_NODE])
@pytest.mark.parametrize("shape", [0, 1, 1000, (77, 3, 2)])
def test_arrays_are_allocated_on_page_boundaries(dtype, shape):
    for array in (host_memory.empty(shape, dtype), host_memory.zeros(shape, dtype)):
        assert array.dtype == np.dtype(dtype) and array.shape == np.empty(shape, dtype).shape
        assert array.flags["C_CONTIGUOUS"] and (array.size == 0 or array.ctypes.data % host_memory.ALIGNMENT == 0)
    assert not np.any(host_memory.zeros(shape, dtype).view(np.uint8))


def test_aligned_copies_only_what_is_not_aligned():
    inside = host_memory.zeros(100, np.float32)
    assert host_memory.aligned(inside) is inside
    offset = inside[1:]
    moved = host_memory.aligned(offset)
    assert moved is not offset and moved.ctypes.data % host_memory.ALIGNMENT == 0
    assert np.array_equal(moved, offset)
    copied = host_memory.copy(inside)
    copied[0] = 1.0
    assert inside[0] == 0.0


def small_scene():
    scene = clrender.load_scene("scenes/cornell_box.json")
    return replace(scene, camera=replace(scene.camera, resolution=(16, 12)))


def test_a_cpu_device_reads_the_scene_arrays_in_place():
    renderer = clrender.Renderer(small_scene(), TEST_DEVICE)
    if not (renderer.device.type & cl.device_type.CPU and renderer.device.host_unified_memory):
        pytest.skip("a device with memory of its own gets copies")
    for name, buffer in zip(renderer.ARRAYS, renderer._buffers):
        assert buffer.flags & cl.mem_flags.USE_HOST_PTR, name
        assert buffer.hostbuf.ctypes.data % host_memory.ALIGNMENT == 0, name
    # The large arrays are the renderer's own, not copies of them.
    for name in ("nodes", "blocks", "shading", "info"):
        assert renderer._buffers[renderer.ARRAYS.index(name)].hostbuf is getattr(renderer.arrays, name), name


def test_an_environment_image_is_read_in_place(tmp_path):
    # Its texels are tens of MB in the real scenes: a copy cost the living room 0.03-0.07 s.
    description = json.loads(Path("scenes/cornell_box.json").read_text())
    description["camera"]["resolution"] = [16, 12]
    description["lights"] = [{"type": "environment", "file": "sky.exr"}]
    clrender.save_image(np.random.default_rng(1).uniform(0.1, 1.0, (8, 16, 3)).astype(np.float32), tmp_path / "sky.exr")
    renderer = clrender.Renderer(clrender.load_scene_dict(description, base_dir=tmp_path), TEST_DEVICE)
    if not (renderer.device.type & cl.device_type.CPU and renderer.device.host_unified_memory):
        pytest.skip("a device with memory of its own gets copies")
    assert renderer._buffers[renderer.ARRAYS.index("env_texels")].hostbuf is renderer.arrays.env_texels


def test_an_updated_array_is_the_renderers_copy():
    # update_array keeps a copy: a later change to the caller's array does not reach the device.
    scene = small_scene()
    renderer = clrender.Renderer(scene, TEST_DEVICE)
    expected = renderer.render(spp=2, seed=1).image
    materials = renderer.arrays.materials.copy()
    renderer.update_array("materials", materials)
    materials.view(np.uint8)[:] = 0
    assert np.array_equal(renderer.render(spp=2, seed=1).image, expected)
