"""What the device can hold: the one place where numbers from users are checked.

The kernel reads int32 integers, a uint32 seed and float32 reals, so a number that is valid
JSON, a valid Python int or a finite float64 may still not fit (`render.seed` 2^32, `rr_depth`
1e12, a radiance of 1e39 that rounds to infinity, a radius of 1e-50 that rounds to 0). The scene
loader (errors name the JSON path), the command line (the flag) and the API (the parameter) all
check through `number` and `float32_values`, and the render settings they share are bounded by
one table, `SETTINGS`. docs/errors.md and docs/scene-format.md list the limits.
"""
import math
import numbers
import reprlib

import numpy as np

from .errors import ArgumentError, SceneError

INT32_MAX = 2**31 - 1
UINT32_MAX = 2**32 - 1
FLOAT32_MAX = float(np.finfo(np.float32).max)

MAX_SPP = 2**24            # the accumulator counts samples per pixel in float32: exact up to 2^24
MAX_DEPTH = 8192           # path vertices: deep enough for lossless furnaces, short launches where
                           # roulette cannot end paths
MAX_RESOLUTION = 16384     # pixels per image side
MAX_EXPOSURE = 64.0        # stops: 2^64 keeps any float32 radiance's tone mapping finite in float64
MAX_TRIANGLES = 2**28      # triangle, node and emitter indices are int32 with room for the BVH
MAX_TRANSFORM_CONDITION = 1e12   # largest / smallest stretch of a transform: beyond, it is singular
MAX_IMAGE_VALUES = 2**29   # width x height x channels of an image file read (textures, environment
                           # maps): 2 GiB as float32, e.g. 16384 x 8192 RGBA; checked before reading

# Bytes of a file a reader reads, checked before the first one is read (files.py).
MAX_SCENE_FILE_BYTES = 2**28   # a JSON or XML scene file, and all the files an XML scene includes
MAX_MESH_FILE_BYTES = 2**34    # OBJ, PLY, serialized: 16 GiB, beyond any mesh of MAX_TRIANGLES
MAX_GRID_FILE_BYTES = 2**33    # .vol, .npy, .npz: 8 GiB
MAX_XML_INCLUDES = 1024        # <include> elements one scene may expand (include graphs double per level)
MAX_SUBSTITUTED_CHARS = 2**24  # characters $name substitution may add over a whole XML scene

MAX_SHADING_SAMPLES = 1024 # the direct integrator's light or BSDF samples per camera hit: a ray each

MIN_MARCH_STEP = 1e-3       # ray marching's step, in voxels: below, a march takes millions of steps
MAX_LOCAL_WORKERS = 1024   # processes of a local Dask cluster, each with its own device context

# Render settings shared by the scene's `render` object, the CLI flags and the API parameters
# (local and distributed rendering): name -> (integer?, low, high, low excluded?).
SETTINGS = {
    "spp": (True, 1, MAX_SPP, False),
    "max_depth": (True, 1, MAX_DEPTH, False),
    "rr_depth": (True, 1, INT32_MAX, False),
    "seed": (True, 0, UINT32_MAX, False),
    "samples_per_pass": (True, 1, MAX_SPP, False),
    "step": (False, MIN_MARCH_STEP, None, False),
    "time_limit": (False, 0.0, None, True),
    "exposure": (False, -MAX_EXPOSURE, MAX_EXPOSURE, False),
    "workers": (True, 1, MAX_LOCAL_WORKERS, False),
    "tiles": (True, 1, INT32_MAX, False),
    "chunk_seconds": (False, 0.0, None, True),
    "samples_per_chunk": (True, 1, MAX_SPP, False),
    "scenes_in_flight": (True, 1, INT32_MAX, False),
    "connect_timeout": (False, 0.0, None, True),
    "chunk_timeout": (False, 0.0, None, True),
}


def number(value, where, error=ArgumentError, low=None, high=None, low_open=False, integer=False):
    """`value` as an int (integer=True: int32 unless `high` says more, as for the uint32 seed)
    or a float that stays finite in float32, within [low, high] (low excluded when
    `low_open`, also after rounding to float32); otherwise raises `error(where, message)`."""
    kind = "an integer" if integer else "a number"
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral if integer else numbers.Real)):
        raise error(where, f"must be {kind}, got {show(value)}")
    if integer:
        value = int(value)
        low = -INT32_MAX - 1 if low is None else low
        high = INT32_MAX if high is None else high      # above int32 only where asked (seeds)
    else:
        try:
            value = float(value)
        except OverflowError:
            raise error(where, f"is too large, got {show(value)}") from None
        if not math.isfinite(value):
            raise error(where, f"must be finite, got {show(value)}")
        if abs(value) > FLOAT32_MAX:
            raise error(where, f"is beyond the float32 range (+-{FLOAT32_MAX:.4g}), got {show(value)}")
    if low is not None and (value <= low if low_open else value < low):
        raise error(where, f"must be {'>' if low_open else '>='} {low}, got {show(value)}")
    if high is not None and value > high:
        raise error(where, f"must be <= {high}, got {show(value)}")
    if low_open and not integer and low is not None and float(np.float32(value)) <= low:
        raise error(where, f"rounds to {low} in float32, got {show(value)}")
    return value


def setting(name, value, where=None, error=ArgumentError):
    """A render setting (`SETTINGS`) from the scene, a flag or a parameter; `where` defaults to
    the setting's name."""
    integer, low, high, low_open = SETTINGS[name]
    return number(value, where or name, error, low=low, high=high, low_open=low_open, integer=integer)


def check_settings(**given):
    """Check the settings given by name (None: not given) against `SETTINGS` (ArgumentError)."""
    for name, value in given.items():
        if value is not None:
            setting(name, value)


def float32_values(values, where, error=ArgumentError):
    """Raise unless every value of an array stays finite in float32 (a derived quantity such as
    sigma * scale, or a vertex read from a file). Returns the values as float64, or as they are
    when they are float32 already (a large image is checked without a copy)."""
    values = np.asarray(values)
    if values.dtype == np.float32 and values.size and np.isfinite(values.max()) and np.isfinite(values.min()):
        return values   # max and min propagate NaN: two passes without a temporary (a 4096 x 2048 map)
    if values.dtype != np.float32:
        values = values.astype(float)
    if np.isfinite(values).all() and (values.dtype == np.float32 or not values.size
                                      or np.abs(values).max() <= FLOAT32_MAX):
        return values
    bad = ~np.isfinite(values) | (np.abs(values) > FLOAT32_MAX)
    if np.any(bad):
        worst = values[bad].flat[0]
        raise error(where, f"must be finite in float32 (|x| <= {FLOAT32_MAX:.4g}), got {worst!r}")
    return values


_SHORT = reprlib.Repr()
_SHORT.maxlevel, _SHORT.maxstring, _SHORT.maxlong, _SHORT.maxother = 3, 40, 40, 40


def show(value):
    """A short rendering of any value for a message: a 400-digit integer, a long string or a
    list nested 10^5 deep stay readable (and repr cannot recurse or refuse)."""
    try:
        return _SHORT.repr(value)
    except (RecursionError, ValueError):
        return f"a {type(value).__name__}"


# --------------------------------------------------------------------------------------------
# Memory of the device (checked before anything is allocated)
# --------------------------------------------------------------------------------------------
PIXEL_BYTES = 16 + 16 + 4   # accumulator float4, aux geometry float4, aux object id int

# Where in the scene each device array comes from, for messages about its size.
ARRAY_ORIGINS = {"nodes": "shapes", "blocks": "shapes", "spheres": "shapes", "shading": "shapes",
                 "info": "shapes", "emitters": "shapes", "emitter_cdf": "shapes", "materials": "materials",
                 "specular_albedo": "materials", "media": "media", "grid_data": "media",
                 "majorant_data": "media", "env_texels": "lights", "env_cdf": "lights", "uvs": "shapes",
                 "textures": "textures", "texels": "textures"}


def check_image_fits(resolution, device):
    """The image's buffers fit `device` (an OpenCL device): the accumulator in one allocation,
    all of them in its memory. A 16384^2 image needs 9 GiB."""
    width, height = resolution
    if width * height * 16 > device.max_mem_alloc_size or width * height * PIXEL_BYTES > device.global_mem_size:
        raise SceneError("camera.resolution", f"{width} x {height} pixels need {width * height * PIXEL_BYTES / 2**20:.0f} "
                                              f"MiB of buffers; {_memory_of(device)}")


def check_arrays_fit(arrays, device):
    """The scene's arrays (name -> numpy array) fit `device`, each in one allocation."""
    sizes = {name: array.nbytes for name, array in arrays.items()}
    name = max(sizes, key=sizes.get)
    if sizes[name] > device.max_mem_alloc_size or sum(sizes.values()) > device.global_mem_size:
        raise SceneError(ARRAY_ORIGINS.get(name, ""), f"the scene needs {sum(sizes.values()) / 2**20:.0f} MiB on the "
                                                      f"device ({name}: {sizes[name] / 2**20:.0f} MiB); "
                                                      f"{_memory_of(device)}")


def _memory_of(device):
    return (f"{device.name.strip()} allocates at most {device.max_mem_alloc_size / 2**20:.0f} MiB at once "
            f"and {device.global_mem_size / 2**20:.0f} MiB in all")
