"""Device choice, the program cache and the error metrics."""
import gc
import os

import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender import device as device_module
from clrender.device import build_program
from conftest import no_features


def test_device_choice_by_kind_index_and_environment(monkeypatch):
    cpu = clrender.choose_device("cpu")
    assert cpu.type & cl.device_type.CPU
    assert clrender.choose_device("0").int_ptr == clrender.list_devices()[0][2].int_ptr
    monkeypatch.setenv("CLRENDER_DEVICE", "cpu")
    assert clrender.choose_device().int_ptr == cpu.int_ptr
    with pytest.raises(ValueError, match="out of range"):
        clrender.choose_device(str(len(clrender.list_devices())))
    with pytest.raises(ValueError, match="no OpenCL device matches"):
        clrender.choose_device("no-such-device-name")


def test_programs_are_cached_in_memory_and_on_disk(device, tmp_path, monkeypatch):
    monkeypatch.setenv("CLRENDER_CACHE_DIR", str(tmp_path))
    context = cl.Context([device])
    first = build_program(context, no_features())
    assert build_program(context, no_features()) is first          # memory
    assert build_program(context, no_features(TOON=1)) is not first  # other defines
    assert any(os.scandir(tmp_path))                                # disk: binaries were stored
    again = build_program(cl.Context([device]), no_features())      # a new context, from disk
    assert again is not first and again.get_info(cl.program_info.NUM_DEVICES) == 1


def test_a_program_always_belongs_to_the_context_it_is_built_for(device):
    # Contexts created and collected one after another often reuse an id(): the memory cache
    # must not hand over a collected context's program (on Intel's runtime: INVALID_CONTEXT).
    for _ in range(20):
        context = cl.Context([device])
        program = build_program(context, no_features())
        assert program.get_info(cl.program_info.CONTEXT).int_ptr == context.int_ptr
        cl.Kernel(program, "render_pass")
        del context, program
        gc.collect()


def test_metrics():
    reference = np.ones((4, 4, 3))
    image = reference + 0.1
    assert clrender.mse(image, reference) == pytest.approx(0.01)
    assert clrender.rmse(image, reference) == pytest.approx(0.1)
    assert clrender.relative_mse(image, reference, epsilon=0.0) == pytest.approx(0.01)
    assert clrender.efficiency(0.01, 2.0) == pytest.approx(50.0)
    assert clrender.efficiency(0.0, 2.0) == float("inf")
