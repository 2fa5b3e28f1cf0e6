"""OpenCL device choice and kernel program builds, cached per device, source and defines.

The kernel source is assembled on the host: #include "x.h" lines are expanded (each file once)
with #line markers so compiler messages name the right file, and the layout enumerations are
prepended. The assembled text is therefore the complete input, and its hash keys the cache.
"""
import hashlib
import os
import re
from importlib import resources
from pathlib import Path

import pyopencl as cl

from . import layout
from .errors import KernelBuildError

BUILD_OPTIONS = "-cl-std=CL1.2 -cl-mad-enable"
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$')
_programs = {}  # in-memory cache: (context id, device, source hash, options) -> Program


def kernel_dir():
    """kernels/ beside the package in a source checkout, else the installed package data."""
    checkout = Path(__file__).resolve().parent.parent / "kernels"
    return checkout if (checkout / "integrator.cl").is_file() else Path(str(resources.files("clrender.kernels")))


def list_devices():
    """All OpenCL devices as (index, platform, device), in a stable order."""
    found = []
    for platform in cl.get_platforms():
        for device in platform.get_devices():
            found.append((len(found), platform, device))
    return found


def choose_device(spec=None):
    """Pick a device: `spec` (or $CLRENDER_DEVICE) is an index, 'cpu', 'gpu', or a name part.

    Default: the first GPU, else the first device.
    """
    spec = spec if spec is not None else os.environ.get("CLRENDER_DEVICE")
    devices = list_devices()
    if not devices:
        raise RuntimeError("no OpenCL device found: install an OpenCL driver (e.g. pocl-opencl-icd)")
    if spec is None or str(spec).strip() == "":
        gpus = [d for _, _, d in devices if d.type & cl.device_type.GPU]
        return gpus[0] if gpus else devices[0][2]
    spec = str(spec).strip()
    if spec.isdigit():
        index = int(spec)
        if index >= len(devices):
            raise ValueError(f"device index {index} out of range: {len(devices)} device(s); see `clrender devices`")
        return devices[index][2]
    kinds = {"cpu": cl.device_type.CPU, "gpu": cl.device_type.GPU, "accelerator": cl.device_type.ACCELERATOR}
    if spec.lower() in kinds:
        matches = [d for _, _, d in devices if d.type & kinds[spec.lower()]]
    else:
        matches = [d for _, _, d in devices if spec.lower() in d.name.lower()]
    if not matches:
        raise ValueError(f"no OpenCL device matches {spec!r}; see `clrender devices`")
    return matches[0]


def kernel_source(entry="integrator.cl"):
    """The entry file with its includes expanded once each, preceded by the enumerations."""
    root = kernel_dir()
    seen = set()

    def expand(relative):
        if relative in seen:
            return ""
        seen.add(relative)
        path = root / relative
        if not path.is_file():
            raise KernelBuildError(f"kernel file not found: {path}")
        out = [f'#line 1 "{relative}"']
        for number, line in enumerate(path.read_text().splitlines(), start=1):
            match = _INCLUDE.match(line)
            if match:
                out.append(expand(match.group(1)))
                out.append(f'#line {number + 1} "{relative}"')
            else:
                out.append(line)
        return "\n".join(out)

    return layout.c_constants() + expand(entry) + "\n"


def define_options(features):
    return " ".join(f"-D{name}={int(value)}" for name, value in sorted(features.items()))


def cache_dir():
    return os.environ.get("CLRENDER_CACHE_DIR") or str(Path.home() / ".cache" / "clrender")


def build_program(context, features, entry="integrator.cl"):
    """Build (or fetch from the memory and disk caches) the program for `features`."""
    source = kernel_source(entry)
    options = f"{BUILD_OPTIONS} {define_options(features)}"
    device = context.devices[0]
    key = (id(context), device.int_ptr, hashlib.sha256(source.encode()).hexdigest(), options)
    program = _programs.get(key)
    if program is None:
        program = cl.Program(context, source)
        try:
            # pyopencl keeps built binaries on disk, keyed by device, source and options.
            program.build(options=options, cache_dir=cache_dir())
        except cl.RuntimeError as e:
            raise KernelBuildError(f"kernel build failed for {entry} with {options}:\n{e}") from None
        _programs[key] = program
    return program
