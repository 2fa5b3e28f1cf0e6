"""Device choice, the program cache and the error metrics."""
import os
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender import device as device_module
from clrender.device import build_program
from conftest import no_features, oclgrind_library

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_device_choice_by_kind_index_and_environment(monkeypatch, device):
    # The suite's device's kind: a machine with a GPU driver alone has no CPU device.
    kind, flag = ("gpu", cl.device_type.GPU) if device.type & cl.device_type.GPU else ("cpu", cl.device_type.CPU)
    chosen = clrender.choose_device(kind)
    assert chosen.type & flag
    assert clrender.choose_device("0").int_ptr == clrender.list_devices()[0][2].int_ptr
    monkeypatch.setenv("CLRENDER_DEVICE", kind)
    assert clrender.choose_device().int_ptr == chosen.int_ptr
    with pytest.raises(ValueError, match="out of range"):
        clrender.choose_device(str(len(clrender.list_devices())))
    with pytest.raises(ValueError, match="no OpenCL device matches"):
        clrender.choose_device("no-such-device-name")


def fake_devices(with_gpu):
    """(index, platform, device) as list_devices gives them, for a machine with Oclgrind, Intel's
    CPU runtime, PoCL and perhaps an NVIDIA GPU (the CPU named by two implementations)."""
    t = cl.device_type
    rows = [("Oclgrind", "Oclgrind", "Oclgrind Simulator", "Oclgrind", t.CPU | t.GPU | t.ACCELERATOR | t.DEFAULT),
            ("Intel(R) OpenCL", "Intel(R) Corporation", "AMD EPYC 7B13", "Intel(R) Corporation", t.CPU),
            ("Portable Computing Language", "The pocl project", "pthread-AMD EPYC 7B13", "AuthenticAMD", t.CPU)]
    if with_gpu:
        rows.append(("NVIDIA CUDA", "NVIDIA Corporation", "NVIDIA H100", "NVIDIA Corporation", t.GPU))
    return [(i, SimpleNamespace(name=p, vendor=pv, int_ptr=100 + i),
             SimpleNamespace(name=d, vendor=dv, type=kind, int_ptr=200 + i))
            for i, (p, pv, d, dv, kind) in enumerate(rows)]


@pytest.mark.parametrize("with_gpu", [False, True])
def test_device_choice_by_platform_name_is_unambiguous(monkeypatch, with_gpu):
    devices = fake_devices(with_gpu)
    monkeypatch.setattr(device_module, "list_devices", lambda: devices)
    monkeypatch.delenv("CLRENDER_DEVICE", raising=False)
    name = lambda spec: clrender.choose_device(spec).name
    assert name(None) == ("NVIDIA H100" if with_gpu else "AMD EPYC 7B13")   # never the simulator
    assert name("cpu") == "AMD EPYC 7B13" and name("0") == "Oclgrind Simulator"
    assert name("intel") == "AMD EPYC 7B13" and name("pocl") == "pthread-AMD EPYC 7B13"
    assert name("oclgrind") == "Oclgrind Simulator" and name("Portable") == "pthread-AMD EPYC 7B13"
    if with_gpu:
        assert name("gpu") == "NVIDIA H100" and name("nvidia") == "NVIDIA H100"
    for spec in ("amd", "EPYC"):   # the CPU under two implementations
        with pytest.raises(ValueError, match="ambiguous.*Intel.*Portable"):
            clrender.choose_device(spec)


def test_programs_are_cached_in_memory_and_on_disk(device, tmp_path, monkeypatch):
    monkeypatch.setenv("CLRENDER_CACHE_DIR", str(tmp_path))
    context = cl.Context([device])
    first = build_program(context, no_features())
    assert build_program(context, no_features()) is first          # memory
    assert build_program(context, no_features(TOON=1)) is not first  # other defines
    assert any(os.scandir(tmp_path))                                # disk: binaries were stored
    again = build_program(cl.Context([device]), no_features())      # a new context, from disk
    assert again is not first and again.get_info(cl.program_info.NUM_DEVICES) == 1


def test_a_program_always_belongs_to_the_context_it_is_built_for(device, monkeypatch):
    # A collected context's id() is reused by later objects (pyopencl's Program lets go of its
    # context after a source build): a memory cache keyed by id(context) once handed a dead
    # context's program to a new context (Intel's runtime: INVALID_CONTEXT). Here every id()
    # in the device module coincides, which keying by id could not survive.
    monkeypatch.setattr(device_module, "id", lambda obj: 0, raising=False)
    for context in [cl.Context([device]), cl.Context([device])]:
        program = build_program(context, no_features())
        assert program.get_info(cl.program_info.CONTEXT).int_ptr == context.int_ptr


def test_oclgrind_build_options_key_the_program_caches(device, tmp_path, monkeypatch):
    # Oclgrind appends $OCLGRIND_BUILD_OPTIONS to every build: the value is part of the source,
    # which keys clrender's caches and pyopencl's, so a build under other options is another one.
    monkeypatch.setenv("CLRENDER_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("OCLGRIND_BUILD_OPTIONS", raising=False)
    plain = device_module.kernel_source()
    monkeypatch.setenv("OCLGRIND_BUILD_OPTIONS", "-cl-opt-disable")
    assert device_module.kernel_source() == "// OCLGRIND_BUILD_OPTIONS='-cl-opt-disable'\n" + plain
    context = cl.Context([device])
    build_program(context, no_features())
    monkeypatch.delenv("OCLGRIND_BUILD_OPTIONS")
    build_program(context, no_features())
    assert len(list(tmp_path.glob("*.clbin"))) == 2


@pytest.mark.skipif(oclgrind_library() is None, reason="Oclgrind is not installed (apt-get install oclgrind)")
def test_a_program_built_by_oclgrind_under_other_options_is_not_reused(tmp_path):
    # Oclgrind 21.10 cannot run what its optimiser makes of the kernel (llvm.bitreverse), so it
    # runs with OCLGRIND_BUILD_OPTIONS=-cl-opt-disable (docs/portability.md); a program built
    # without, and cached by clrender and pyopencl, was once taken for a build with it.
    (tmp_path / "vendors").mkdir()
    (tmp_path / "vendors" / "oclgrind.icd").write_text(oclgrind_library() + "\n")
    env = dict(os.environ, OCL_ICD_VENDORS=str(tmp_path / "vendors"), XDG_CACHE_HOME=str(tmp_path / "xdg"),
               CLRENDER_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=REPO, CLRENDER_DEVICE="oclgrind")
    env.pop("PYOPENCL_NO_CACHE", None)
    env.pop("OCLGRIND_BUILD_OPTIONS", None)
    code = ("import clrender\n"
            "scene = {'camera': {'position': [0, 0, 3], 'look_at': [0, 0, 0], 'resolution': [2, 2]},\n"
            "         'materials': [{'name': 'm', 'type': 'diffuse'}], 'shapes': [{'type': 'sphere', 'material': 'm'}],\n"
            "         'lights': [{'type': 'environment', 'radiance': 1.0}], 'render': {'max_depth': 2}}\n"
            "print(clrender.render(scene, spp=1).mean())\n")
    run = lambda env: subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    run(env)   # builds and caches (and fails, with Oclgrind's optimiser)
    result = run(dict(env, OCLGRIND_BUILD_OPTIONS="-cl-opt-disable"))
    assert result.returncode == 0 and float(result.stdout) > 0, result.stderr


def test_metrics():
    reference = np.ones((4, 4, 3))
    image = reference + 0.1
    assert clrender.mse(image, reference) == pytest.approx(0.01)
    assert clrender.rmse(image, reference) == pytest.approx(0.1)
    assert clrender.relative_mse(image, reference, epsilon=0.0) == pytest.approx(0.01)
    assert clrender.efficiency(0.01, 2.0) == pytest.approx(50.0)
    assert clrender.efficiency(0.0, 2.0) == float("inf")
