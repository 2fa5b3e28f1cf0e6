"""OpenCL device choice and kernel program builds, cached per device, source and defines.

The kernel source is assembled on the host: #include "x.h" lines are expanded (each file once,
where it is first included: so no include may sit inside an #if, see tests/test_compile.py)
with #line markers so compiler messages name the right file, and the layout enumerations are
prepended, and so are the values of the environment variables an implementation reads when it
builds (BUILD_ENVIRONMENT). The assembled text is therefore the complete input: its hash, with the
device, driver and options, keys an in-memory cache and a disk cache of program binaries
($CLRENDER_CACHE_DIR, default ~/.cache/clrender), and pyopencl's own cache keys on it too. A disk
entry carries the driver's identity and a checksum of the binary, verified before the binary
reaches the driver (a truncated binary crashes PoCL).
"""
import contextlib
import hashlib
import os
import re
import tempfile
import warnings
from importlib import resources
from pathlib import Path

import pyopencl as cl

from . import layout
from .disk_cache import cache_dir
from .errors import ArgumentError, DeviceError, KernelBuildError

BUILD_OPTIONS = "-cl-std=CL1.2 -cl-mad-enable"
# Environment variables that change what an implementation builds: Oclgrind appends
# OCLGRIND_BUILD_OPTIONS to every build's options (-cl-opt-disable, docs/portability.md).
BUILD_ENVIRONMENT = ("OCLGRIND_BUILD_OPTIONS",)
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$')


def kernel_dir():
    """kernels/ beside the package in a source checkout, else the installed package data."""
    checkout = Path(__file__).resolve().parent.parent / "kernels"
    return checkout if (checkout / "integrator.cl").is_file() else Path(str(resources.files("clrender.kernels")))


def list_devices():
    """All OpenCL devices as (index, platform, device), in a stable order; none without a driver."""
    try:
        platforms = cl.get_platforms()
    except cl.Error:   # the ICD loader found no platform at all (PLATFORM_NOT_FOUND_KHR)
        return []
    found = []
    for platform in platforms:
        try:
            devices = platform.get_devices()
        except cl.Error:   # a platform without devices (DEVICE_NOT_FOUND)
            continue
        for device in devices:
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
    where = "device" if spec is not None else "CLRENDER_DEVICE"   # the error names where the choice came from
    spec = spec if spec is not None else os.environ.get("CLRENDER_DEVICE")
    devices = list_devices()
    if not devices:
        raise DeviceError("no OpenCL device found: install an OpenCL driver (e.g. pocl-opencl-icd)")
    real = [(p, d) for _, p, d in devices if not is_simulator(d)]
    if spec is None or str(spec).strip() == "":
        gpus = [d for _, d in real if d.type & cl.device_type.GPU]
        return gpus[0] if gpus else (real[0][1] if real else devices[0][2])
    spec = str(spec).strip()
    if spec.isdigit():
        index = int(spec)
        if index >= len(devices):
            raise ArgumentError(where, f"index {index} out of range: {len(devices)} device(s); "
                                       "see `clrender devices`")
        return devices[index][2]
    if spec.lower() in _KINDS:
        matches = [(p, d) for p, d in real if d.type & _KINDS[spec.lower()]]
    else:
        matches = [(p, d) for _, p, d in devices
                   if any(spec.lower() in name.lower() for name in device_names(p, d))]
    if not matches:
        raise ArgumentError(where, f"no OpenCL device matches {spec!r}; see `clrender devices`")
    platforms = {p.int_ptr: p.name for p, _ in matches}
    if spec.lower() not in _KINDS and len(platforms) > 1:
        raise ArgumentError(where, f"{spec!r} is ambiguous: it matches devices of the platforms "
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

    return build_environment() + layout.c_constants() + expand(entry) + "\n"


def build_environment():
    """The BUILD_ENVIRONMENT variables that are set, as comment lines heading the source: a
    program built under other values is another program to every cache keyed by the source."""
    return "".join(f"// {name}={os.environ[name]!r}\n" for name in BUILD_ENVIRONMENT if name in os.environ)


def define_options(features):
    return " ".join(f"-D{name}={int(value)}" for name, value in sorted(features.items()))


def build_program(context, features, entry=None):
    """Build the program for `features` (from `entry`, default the render kernel they select),
    or fetch it from the memory or disk cache."""
    key, source, options, entry = _program_identity(context, features, entry)
    programs = _memory_cache(context)
    if key not in programs:
        programs[key] = _load_binary(context, key, options) or _build_from_source(context, source, options, key, entry)
    return programs[key]


def program_key(context, features, entry=None):
    """The build key (device, driver, options, source) of the program build_program makes for
    these arguments, without building it: what the tables a program computes depend on
    (disk_cache.py)."""
    return _program_identity(context, features, entry)[0]


def _program_identity(context, features, entry):
    from .features import entry_file

    entry = entry or entry_file(features)
    source = kernel_source(entry)
    options = f"{BUILD_OPTIONS} {define_options(features)}"
    identity = "\n".join([_device_identity(context.devices[0]), options, source])
    return hashlib.sha256(identity.encode()).hexdigest(), source, options, entry


def _memory_cache(context):
    """The programs built for `context`, kept on the context object itself: a cache keyed by
    id(context) handed a collected context's program to a new context that got the same id
    (Intel's runtime then fails with INVALID_CONTEXT)."""
    if not hasattr(context, "_clrender_programs"):
        context._clrender_programs = {}
    return context._clrender_programs


class KernelCacheWarning(UserWarning):
    """A disk cache entry was damaged or foreign and has been rebuilt."""


_CACHE_MAGIC = b"clrender kernel cache 1\n"


def _binary_path(key):
    return Path(cache_dir()) / f"{key}.clbin"


def _device_identity(device):
    return "\n".join([device.platform.name, device.platform.version, device.name, device.driver_version])


def _cache_entry(binary, identity):
    """magic, identity length (8 bytes), identity, SHA-256 of the binary (32 bytes), binary."""
    identity = identity.encode()
    return (_CACHE_MAGIC + len(identity).to_bytes(8, "little") + identity
            + hashlib.sha256(binary).digest() + binary)


def _cached_binary(entry, identity):
    """The binary stored in a cache entry, or the reason it cannot be trusted."""
    if not entry.startswith(_CACHE_MAGIC):
        return None, "unknown format"
    at = len(_CACHE_MAGIC)
    size = int.from_bytes(entry[at:at + 8], "little")
    stored = entry[at + 8:at + 8 + size]
    if len(entry) < at + 8 + size + 32:
        return None, "truncated"
    if stored != identity.encode():
        return None, "built by another driver"
    checksum = entry[at + 8 + size:at + 40 + size]
    binary = entry[at + 40 + size:]
    if len(checksum) < 32 or not binary or hashlib.sha256(binary).digest() != checksum:
        return None, "checksum mismatch (truncated or corrupted)"
    return binary, None


@contextlib.contextmanager
def _quiet_compiler():
    """pyopencl warns whenever a driver's build log is not empty (NVIDIA's notes, remarks):
    nothing a user of a scene can act on. PYOPENCL_COMPILER_OUTPUT=1 shows the logs, as in
    pyopencl; a failed build raises with its log either way."""
    with warnings.catch_warnings():
        if not os.environ.get("PYOPENCL_COMPILER_OUTPUT"):
            warnings.simplefilter("ignore", cl.CompilerWarning)
        yield


def _load_binary(context, key, options):
    path = _binary_path(key)
    try:
        entry = path.read_bytes()
    except OSError:
        return None    # no entry (or unreadable): build from source
    binary, problem = _cached_binary(entry, _device_identity(context.devices[0]))
    if binary is None:
        warnings.warn(f"kernel cache entry {path} is unusable ({problem}); rebuilding it",
                      KernelCacheWarning, stacklevel=3)
        return None
    try:
        program = cl.Program(context, context.devices, [binary])
        with _quiet_compiler():
            return program.build(options=options)
    except cl.Error:
        return None  # a binary the driver no longer accepts (e.g. after an update): rebuild


def _build_from_source(context, source, options, key, entry):
    try:
        with _quiet_compiler():
            program = cl.Program(context, source).build(options=options)
    except cl.RuntimeError as e:
        raise KernelBuildError(f"kernel build failed for {entry} with {options}:\n{e}") from None
    binary = program.get_info(cl.program_info.BINARIES)[0]
    path = _binary_path(key)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{key}.")
        with os.fdopen(fd, "wb") as f:
            f.write(_cache_entry(binary, _device_identity(context.devices[0])))
        os.replace(tmp, path)
    except OSError:
        pass  # an unwritable cache only costs the next process a rebuild
    return program


@contextlib.contextmanager
def device_errors():
    """Errors of the OpenCL runtime (and host memory) as DeviceError; usable as a decorator."""
    try:
        yield
    except cl.MemoryError as e:
        raise DeviceError(f"the OpenCL device ran out of memory ({e}); render a smaller image or scene") from None
    except MemoryError:
        raise DeviceError("out of host memory; render a smaller image or scene") from None
    except cl.Error as e:
        raise DeviceError(f"OpenCL error: {e}") from None
