"""Light paths: caustics traced from the lights. The paths light -> delta+ -> non-delta -> ... ->
camera (read as events: one or more delta events from the light, then a non-delta one, ending
at a camera whose primary event is non-delta) are the light paths' (kernels/light_paths.cl), and
the path tracer leaves their emission out (kernels/light_paths.h): each path counted once, by
the technique that finds it easily. One light path per EVERY camera samples of a pixel, keyed by
that pixel and sample, so that a tile's passes trace the same light paths however they are
split. Each joins the camera at its non-delta vertices; its records (image position, value) are
splatted with the camera's filter and summed in int64 fixed point, exactly, so tiles, passes and
Dask workers give the same bits in any order. The image adds their sum over the light paths per
pixel, divided by the filter's mass inside the image (as splatting normalises a pixel by the
weights it received).
"""
import math

import numpy as np

from . import filters

EVERY = 8              # camera samples per light path (their own variance is 1e-3 of veach-bidir's)
FIXED_POINT = 2.0**24  # a record's weight in units of 2^-24, rounded
RECORD_FLOATS = 8      # (x, y, 0, 0), (r, g, b, 0)


def applies(scene, features):
    """Whether light paths take the caustics: path tracing (not `direct`), render.light_paths on,
    a pinhole camera, emitters not hidden from it (its rays would pass them, the light paths'
    joins would not), no media, toon shading or masks (the light paths know none of them), some
    material with delta events, some emitting triangle without a texture."""
    settings = scene.render
    if not settings.light_paths or settings.integrator != "path" or settings.hide_emitters:
        return False
    if scene.camera.aperture_radius > 0:
        return False
    if features["MEDIA"] or features["TOON"] or features["GRID_MEDIA"]:
        return False
    materials = [scene.materials[shape.material] for shape in scene.shapes]
    if any(m.opacity < 1 or "opacity" in m.textures for m in materials):
        return False
    emitting = any(np.any(m.emission > 0) and "emission" not in m.textures for m in materials)
    return emitting and any(has_delta_events(m) for m in materials)


def has_delta_events(material):
    """Whether a material can scatter by a delta event: a smooth dielectric (not index-matched)
    or conductor, a thin dielectric, plastic's smooth coat (features.py's smoothness test)."""
    if material.type == "thin_dielectric":
        return True
    if material.type not in ("dielectric", "conductor", "plastic") or material.index_matched:
        return False
    return bool(np.float32(material.roughness) ** 2 < np.float32(1e-3)) and "alpha" not in material.textures


def paths_of(tile, first, count):
    """The light paths of samples first .. first + count - 1 of a tile's pixels."""
    samples = len(range(-(-first // EVERY) * EVERY, first + count, EVERY))
    return tile[2] * tile[3] * samples


def splat(records, camera_filter, width, height):
    """The (height * width, 3) int64 fixed-point sums of `records` ((n, RECORD_FLOATS) float32)
    splatted with the camera's filter (normalised to integrate to 1); records that are not
    finite are left out."""
    sums = np.zeros((height * width, 3), np.int64)
    records = records[np.all(np.isfinite(records[:, [0, 1, 4, 5, 6]]), axis=1)]
    if not len(records):
        return sums
    x, y, value = records[:, 0].astype(float), records[:, 1].astype(float), records[:, 4:7].astype(float)
    mass = float(filters.cumulative(camera_filter, filters.radius(camera_filter)))
    reach = int(math.ceil(filters.radius(camera_filter)))
    offsets = np.arange(-reach, reach + 1)
    column = np.floor(x)[:, None].astype(int) + offsets   # (n, k) pixel columns and their weights
    row = np.floor(y)[:, None].astype(int) + offsets
    wx = filters.evaluate(camera_filter, column + 0.5 - x[:, None]) / mass
    wy = filters.evaluate(camera_filter, row + 0.5 - y[:, None]) / mass
    inside_x, inside_y = (column >= 0) & (column < width), (row >= 0) & (row < height)
    for a in range(len(offsets)):
        for b in range(len(offsets)):
            keep = inside_y[:, a] & inside_x[:, b] & (wy[:, a] * wx[:, b] > 0)
            weight = (wy[keep, a] * wx[keep, b])[:, None]
            units = np.rint(value[keep] * weight * FIXED_POINT).astype(np.int64)
            np.add.at(sums, row[keep, a] * width + column[keep, b], units)
    return sums


def image(sums, paths, camera_filter, width, height):
    """The light paths' (height, width, 3) float32 image from their fixed-point `sums` over
    `paths` light paths of the whole image."""
    if paths == 0:
        return np.zeros((height, width, 3), np.float32)
    per_pixel = paths / (width * height)
    mass = float(filters.cumulative(camera_filter, filters.radius(camera_filter)))
    inside = [(filters.cumulative(camera_filter, n - np.arange(n) - 0.5)
               - filters.cumulative(camera_filter, -np.arange(n) - 0.5)) / mass for n in (width, height)]
    border = inside[1][:, None, None] * inside[0][None, :, None]
    light = sums.reshape(height, width, 3).astype(np.float64) / FIXED_POINT
    return (light / (per_pixel * border)).astype(np.float32)
