"""OpenCL device choice and kernel program builds, cached per device, source and defines.

The kernel source is assembled on the host: #include "x.h" lines are expanded (each file once,
where it is first included: so no include may sit inside an #if, see tests/test_compile.py)
with #line markers so compiler messages name the right file, and the layout enumerations are
prepended. The assembled text is therefore the complete input: its hash, with the device, driver and
options, keys an in-memory cache and a disk cache of program binaries ($CLRENDER_CACHE_DIR,
default ~/.cache/clrender).
"""
import hashlib
import os
import re
import tempfile
from importlib import resources
from pathlib import Path

import pyopencl as cl

from . import layout
from .errors import KernelBuildError

BUILD_OPTIONS = "-cl-std=CL1.2 -cl-mad-enable"
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$')


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


_KINDS = {"cpu": cl.device_type.CPU, "gpu": cl.device_type.GPU, "accelerator": cl.device_type.ACCELERATOR}


def is_simulator(device):
    """A device reporting several kinds at once: Oclgrind reports CPU, GPU and accelerator. It
    checks every memory access and is thousands of times slower, so it is never a default and
    never matches 'cpu' or 'gpu'; name it ('oclgrind') to use it."""
    kinds = [bit for bit in _KINDS.values() if device.type & bit]
    return len(kinds) > 1


def device_names(platform, device):
    """The names a device answers to: its platform's name and vendor, its own name and vendor."""
    return [platform.name, platform.vendor, device.name, device.vendor]


def choose_device(spec=None):
    """Pick a device: `spec` (or $CLRENDER_DEVICE) is an index, 'cpu', 'gpu', or a part of the
    platform's or device's name or vendor (e.g. 'pocl', 'intel', 'nvidia', 'oclgrind').

    Default: the first GPU, else the first device that is not a simulator. A name part that
    matches devices of several platforms is an error (e.g. 'amd' may be the CPU's name under
    two implementations): the choice must be unambiguous.
    """
    spec = spec if spec is not None else os.environ.get("CLRENDER_DEVICE")
    devices = list_devices()
    if not devices:
        raise RuntimeError("no OpenCL device found: install an OpenCL driver (e.g. pocl-opencl-icd)")
    real = [(p, d) for _, p, d in devices if not is_simulator(d)]
    if spec is None or str(spec).strip() == "":
        gpus = [d for _, d in real if d.type & cl.device_type.GPU]
        return gpus[0] if gpus else (real[0][1] if real else devices[0][2])
    spec = str(spec).strip()
    if spec.isdigit():
        index = int(spec)
        if index >= len(devices):
            raise ValueError(f"device index {index} out of range: {len(devices)} device(s); see `clrender devices`")
        return devices[index][2]
    if spec.lower() in _KINDS:
        matches = [(p, d) for p, d in real if d.type & _KINDS[spec.lower()]]
    else:
        matches = [(p, d) for _, p, d in devices
                   if any(spec.lower() in name.lower() for name in device_names(p, d))]
    if not matches:
        raise ValueError(f"no OpenCL device matches {spec!r}; see `clrender devices`")
    platforms = {p.int_ptr: p.name for p, _ in matches}
    if spec.lower() not in _KINDS and len(platforms) > 1:
        raise ValueError(f"device {spec!r} is ambiguous: it matches devices of the platforms "
                         f"{', '.join(sorted(platforms.values()))}; give a platform name or an index "
                         f"(see `clrender devices`)")
    return matches[0][1]


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
    """Build the program for `features`, or fetch it from the memory or disk cache."""
    source = kernel_source(entry)
    options = f"{BUILD_OPTIONS} {define_options(features)}"
    device = context.devices[0]
    identity = "\n".join([device.platform.name, device.platform.version, device.name,
                          device.driver_version, options, source])
    key = hashlib.sha256(identity.encode()).hexdigest()
    programs = _memory_cache(context)
    if key not in programs:
        programs[key] = _load_binary(context, key, options) or _build_from_source(context, source, options, key, entry)
    return programs[key]


def _memory_cache(context):
    """The programs built for `context`, kept on the context object itself: a cache keyed by
    id(context) handed a collected context's program to a new context that got the same id
    (Intel's runtime then fails with INVALID_CONTEXT)."""
    if not hasattr(context, "_clrender_programs"):
        context._clrender_programs = {}
    return context._clrender_programs


def _binary_path(key):
    return Path(cache_dir()) / f"{key}.bin"


def _load_binary(context, key, options):
    path = _binary_path(key)
    if not path.is_file():
        return None
    try:
        program = cl.Program(context, context.devices, [path.read_bytes()])
        return program.build(options=options)
    except cl.Error:
        return None  # a stale or foreign binary (driver update): rebuild from source


def _build_from_source(context, source, options, key, entry):
    try:
        program = cl.Program(context, source).build(options=options)
    except cl.RuntimeError as e:
        raise KernelBuildError(f"kernel build failed for {entry} with {options}:\n{e}") from None
    binary = program.get_info(cl.program_info.BINARIES)[0]
    path = _binary_path(key)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{key}.")
        with os.fdopen(fd, "wb") as f:
            f.write(binary)
        os.replace(tmp, path)
    except OSError:
        pass  # an unwritable cache only costs the next process a rebuild
    return program
