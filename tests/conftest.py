"""Shared fixtures: one OpenCL context for the session (the CPU device unless
$CLRENDER_TEST_DEVICE names another) and helpers for scenes built in code."""
import os

import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender.device import build_program
from clrender.features import FEATURE_VALUES

TEST_DEVICE = os.environ.get("CLRENDER_TEST_DEVICE", "cpu")


@pytest.fixture(scope="session")
def device():
    return clrender.choose_device(TEST_DEVICE)


@pytest.fixture(scope="session")
def context(device):
    return cl.Context([device])


@pytest.fixture(scope="session")
def queue(context):
    return cl.CommandQueue(context)


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
