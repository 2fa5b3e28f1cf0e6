"""Splatting, the host's side (render.filter_method "splat"; kernels/splat.h explains it): which
pixels a pass traces for a tile, the per-pixel arrays of the tile inside them, how many samples a
pass may hold as records, and the gather kernel.

A tile's pixels take samples from every pixel within the filter's reach, so a pass traces the
tile grown by the reach (clipped to the image): the pixels outside the tile are traced again by
the tiles that hold them (distributed.py's strips), with the same random numbers, so each
pixel's sums are those of one render of the whole image."""
import math

import numpy as np
import pyopencl as cl

from . import filters
from .device import build_program
from .features import gather_features

# The gather's work-group size on CPU devices (the kernel skips work-items beyond the tile).
CPU_GATHER_LOCAL_SIZE = (8, 1)
# The records of one pass are at most this many bytes (fewer samples per pass on large images).
RECORDS_BUDGET = 64 << 20


def splats(scene):
    """Whether `scene` is rendered by splatting: its filter reaches beyond a pixel and its
    render.filter_method is "splat"."""
    return scene.render.filter_method == "splat" and scene.camera.filter.type != "box"


def reach(f):
    """The pixels beyond its own (along each axis) whose filters a sample can reach: a sample at
    p in [0, 1) of pixel 0 counts in pixel k when |k + 0.5 - p| < radius."""
    return max(0, math.ceil(filters.radius(f) + 0.5) - 1)


def traced_tile(tile, distance, width, height):
    """The pixels a pass traces for `tile` (x, y, width, height): grown by `distance` on every
    side, within the width x height image."""
    x, y, w, h = tile
    x0, y0 = max(0, x - distance), max(0, y - distance)
    x1, y1 = min(width, x + w + distance), min(height, y + h + distance)
    return (x0, y0, x1 - x0, y1 - y0)


def _window(tile, traced):
    """The (rows, columns) slices of `tile` in the row-major pixel grid of `traced`."""
    x, y, w, h = tile
    return slice(y - traced[1], y - traced[1] + h), slice(x - traced[0], x - traced[0] + w)


def embed(values, tile, traced):
    """A per-pixel array of `tile` (pixels first, row-major) inside one of `traced`, zero outside."""
    grid = np.zeros((traced[3], traced[2]) + values.shape[1:], values.dtype)
    grid[_window(tile, traced)] = values.reshape((tile[3], tile[2]) + values.shape[1:])
    return grid.reshape((-1,) + values.shape[1:])


def crop(values, traced, tile):
    """The pixels of `tile` of a per-pixel array of `traced` (the inverse of embed)."""
    grid = values.reshape((traced[3], traced[2]) + values.shape[1:])
    return np.ascontiguousarray(grid[_window(tile, traced)]).reshape((-1,) + values.shape[1:])


def record_bytes(distance):
    """Bytes of one sample's record for a filter reaching `distance` pixels (kernels/splat.h,
    SPLAT_COMPONENTS: radiance and the weights along x and y)."""
    return 4 * (3 + 2 * (2 * distance + 1))


def samples_per_pass_limit(traced, sample_bytes):
    """The most samples per pixel a pass over `traced` may take: their records, `sample_bytes`
    each, within RECORDS_BUDGET."""
    return max(1, RECORDS_BUDGET // (sample_bytes * traced[2] * traced[3]))


class Gather:
    """The gather kernel of one device (kernels/splat.cl) for a filter reaching `reach` pixels;
    `packets`: the pixels of a row in packets per work-item (features.gather_features; CPUs: 3
    times faster on PoCL, docs/performance.md), else one per work-item."""

    def __init__(self, context, f, packets=False):
        self.reach = reach(f)
        features = gather_features(packets)
        self.lanes = features["LANES"]
        self.kernel = cl.Kernel(build_program(context, features, entry="splat.cl"), "gather_splats")
        # One work-group size on CPUs, whatever the tile (render.CPU_LOCAL_SIZE says why).
        self.local_size = CPU_GATHER_LOCAL_SIZE if context.devices[0].type & cl.device_type.CPU else None

    def __call__(self, queue, tile, params_buffer, records, filtered):
        """Add the records of the pass of `params_buffer` to the sums `filtered` of `tile`."""
        size = (-(-tile[2] // self.lanes), tile[3])
        if self.local_size:
            size = tuple(-(-n // m) * m for n, m in zip(size, self.local_size))
        self.kernel(queue, size, self.local_size, params_buffer, records, filtered)
