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


def camera(position=(0, 0, 5), look_at=(0, 0, 0), fov=30, resolution=(32, 32), up=(0, 1, 0)):
    return {"position": list(position), "look_at": list(look_at), "up": list(up), "fov": fov,
            "resolution": list(resolution)}


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
