"""Shared fixtures: one OpenCL context for the session and helpers for scenes built in code.

The device: $CLRENDER_TEST_DEVICE, as clrender.choose_device reads it (an index, 'cpu', 'gpu' or a
platform or device name: 'pocl', 'intel', 'nvidia'); default 'cpu'. A name matching devices of
several platforms is an error, so the suite never runs on another implementation than the one
named; command-line tests get it through $CLRENDER_DEVICE. The device is printed in pytest's
header.
"""
import os
import subprocess
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender.device import build_program
from clrender.features import FEATURE_VALUES

TEST_DEVICE = os.environ.get("CLRENDER_TEST_DEVICE", "cpu")
# Real Mitsuba 3 scenes written by others (SOURCES.md there), kept beside the checkout, not in it.
REAL_SCENES = Path(__file__).resolve().parent.parent.parent / "shared" / "real-scenes"
# The command line run by the tests (subprocesses) renders on the same device.
os.environ.setdefault("CLRENDER_DEVICE", TEST_DEVICE)


@pytest.fixture(scope="session")
def device():
    return clrender.choose_device(TEST_DEVICE)


def pytest_report_header(config):
    try:
        chosen = clrender.choose_device(TEST_DEVICE)
    except (RuntimeError, ValueError) as e:
        return f"clrender test device {TEST_DEVICE!r}: {e}"
    return (f"clrender test device {TEST_DEVICE!r}: {chosen.name.strip()} [{chosen.platform.name.strip()}, "
            f"{chosen.driver_version.strip()}]")


@pytest.fixture(scope="session")
def context(device):
    return cl.Context([device])


@pytest.fixture(scope="session")
def queue(context):
    return cl.CommandQueue(context)


@pytest.fixture(autouse=True)
def no_discarded_samples(monkeypatch):
    """Every render of the suite must be free of non-finite samples (the renderer drops them as
    black and counts them, which would hide a bias): checked after each Renderer.render."""
    render = clrender.Renderer.render

    def checked(self, *args, **kwargs):
        result = render(self, *args, **kwargs)
        assert result.discarded_samples == 0, f"{result.discarded_samples} non-finite samples were discarded"
        return result

    monkeypatch.setattr(clrender.Renderer, "render", checked)


def no_features(**overrides):
    """Every feature absent, except the overrides."""
    features = {name: values[0] for name, values in FEATURE_VALUES.items()}
    features.update(overrides)
    return features


def build_test_kernels(context, **features):
    return build_program(context, no_features(**features), entry="tests.cl")


def run_test_kernel(context, queue, name, out, *inputs):
    """`out` filled by the kernels/tests.cl kernel `name`, one work-item per entry of `out`, its
    arguments `inputs` (arrays, copied to the device) and then `out`'s buffer."""
    mf = cl.mem_flags
    out_buffer = cl.Buffer(context, mf.WRITE_ONLY, out.nbytes)
    buffers = [cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=array) for array in inputs]
    cl.Kernel(build_test_kernels(context), name)(queue, (len(out),), None, *buffers, out_buffer)
    cl.enqueue_copy(queue, out, out_buffer)
    return out


def camera_rays(context, queue, scene, samples):
    """(origins, directions) of the kernel's camera rays of `scene` (kernels/camera.h, with its
    lens) for samples (image x, y in pixels from the top-left corner, lens u.x, u.y)."""
    from clrender.arrays import build_scene_arrays
    from clrender.render import render_params

    params = render_params(scene, build_scene_arrays(scene), 0, 1, 8, 5, 0)
    samples = np.asarray(samples, np.float32)
    out = run_test_kernel(context, queue, "camera_rays", np.empty((len(samples), 2, 4), np.float32), params, samples)
    return out[:, 0, :3].astype(float), out[:, 1, :3].astype(float)


def delta_light_values(context, queue, scene, points):
    """(radiance (N, 3), distance (N,)) that the kernel's delta_light_sample gives at `points`
    from the first light of `scene` that is not an area light (kernels/lights.h)."""
    from clrender.arrays import build_scene_arrays

    arrays = build_scene_arrays(scene)
    emitter = arrays.emitters[arrays.first_light:arrays.first_light + 1]
    points = np.column_stack([points, np.zeros(len(points))]).astype(np.float32)
    out = run_test_kernel(context, queue, "delta_light_values", np.empty((len(points), 4), np.float32), emitter, points)
    return out[:, :3].astype(float), out[:, 3].astype(float)


def camera(position=(0, 0, 5), look_at=(0, 0, 0), fov=30, resolution=(32, 32), up=(0, 1, 0)):
    return {"position": list(position), "look_at": list(look_at), "up": list(up), "fov": fov,
            "resolution": list(resolution)}


def float32_rtol(device, correctly_rounded):
    """A relative tolerance for float32 kernel results, given the one that holds where division
    and square roots round correctly. OpenCL lets a device divide to 2.5 ulp and take square
    roots to 3 ulp unless the program is built with -cl-fp32-correctly-rounded-divide-sqrt,
    whatever the device reports it could do (NVIDIA's H200 reports CORRECTLY_ROUNDED_DIVIDE_SQRT);
    clrender's programs are not (it slowed NVIDIA's renders 1.4-1.6x): the rounding errors those
    operations feed into then grow to at most 3 times. CPUs divide with IEEE instructions."""
    return correctly_rounded if device.type & cl.device_type.CPU else 3 * correctly_rounded


def z_bound(values, expected, sigmas=5.0):
    """|mean - expected| in units of the standard error of the mean of iid `values`."""
    values = np.asarray(values, dtype=float).ravel()
    standard_error = values.std(ddof=1) / np.sqrt(values.size)
    return abs(values.mean() - expected) / standard_error if standard_error > 0 else (
        0.0 if values.mean() == expected else np.inf)


def sphere(analytic, subdivisions=3, **fields):
    """A sphere shape for the scene format: analytic, or an icosphere with flat facets (the
    geometry tessellated spheres had before analytic ones existed)."""
    shape = {"type": "sphere", **fields}
    if not analytic:
        shape.update(mesh=True, subdivisions=subdivisions, smooth=False)
    return shape


# Debian's libLLVM 19, which Mitsuba's llvm variants load (DRJIT_LIBLLVM_PATH).
LIBLLVM = Path("/usr/lib/x86_64-linux-gnu/libLLVM-19.so")


def use_mitsuba_llvm():
    """Set Mitsuba's llvm_ad_rgb variant, which evaluates pixel filters exactly where scalar_rgb
    tabulates them; the test is skipped where LLVM is missing (`apt-get install libllvm19`)."""
    import mitsuba as mi

    if LIBLLVM.exists():
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", str(LIBLLVM))
    try:
        mi.set_variant("llvm_ad_rgb")
    except (ImportError, AttributeError, RuntimeError) as error:
        pytest.skip(f"Mitsuba's llvm_ad_rgb variant is unavailable (DRJIT_LIBLLVM_PATH): {error}")


def real_scene(relative):
    """The file `relative` of the real scenes; the test is skipped where they are absent (CI)."""
    path = REAL_SCENES / relative
    if not path.exists():
        pytest.skip(f"{path} is absent: the real scenes lie beside the checkout (../shared/real-scenes)")
    return path


def oclgrind_library():
    """Oclgrind's ICD library (from its Debian package's file list), or None."""
    try:
        files = subprocess.run(["dpkg", "-L", "oclgrind"], capture_output=True, text=True).stdout.split()
    except OSError:
        files = []
    for path in files + ["/usr/lib/oclgrind/liboclgrind-rt-icd.so"]:
        if path.endswith("liboclgrind-rt-icd.so") and os.path.isfile(path):
            return path
    return None


def assert_splits_keep_the_bits(renderer):
    """A 16 x 16 scene's 16-spp image (seed 3) the same bits in one pass, in passes of 3, and as
    two strips of two chunks each (as distributed.py renders them), merged."""
    from clrender.distributed import merge_strips
    from clrender.render import Accumulation, image_result

    whole = renderer.render(spp=16, seed=3, samples_per_pass=16).image
    assert np.array_equal(renderer.render(spp=16, seed=3, samples_per_pass=3).image, whole)
    strips = []
    for tile in ((0, 0, 16, 7), (0, 7, 16, 9)):
        state = renderer.accumulate(Accumulation.start(tile), 5, seed=3)
        strips.append(renderer.accumulate(state, 11, seed=3))
    assert np.array_equal(image_result(renderer.scene, merge_strips(renderer.scene, strips)).image, whole)
