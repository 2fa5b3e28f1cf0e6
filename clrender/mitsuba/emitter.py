"""Emitters: lights, the environment, and the emission of shapes.

| plugin | parameter (Mitsuba's default) | clrender |
|---|---|---|
| `area` (in a shape) | `radiance` (1) | the shape's material `emission` (front side only in both) |
| `point` | `intensity` (1), `position` or `to_world` | `point` light |
| `spot` | `intensity` (1), `cutoff_angle` (20), `beam_width` (3/4 of the cutoff), `to_world` (a rotation, uniform scale and translation: it shines along +z from its origin) | `spot` light; a `texture` is an error |
| `directional` | `irradiance` (1), `direction` or to_world(+z) | `directional` light |
| `constant` | `radiance` (1) | constant `environment` |
| `envmap` | `filename`, `scale` (1), `to_world` (a rotation); `mis_compensation` accepted | image `environment`, resampled into clrender's convention (a warning) |

One environment per scene, as in Mitsuba.
"""
import functools
import hashlib
from pathlib import Path

import numpy as np

from .. import disk_cache
from ..errors import FileError
from ..image import load_image
from .texture import color_or_texture
from .transforms import is_rigid, rotation_scale
from .values import fmt

EMITTERS = ("point", "spot", "directional", "constant", "envmap")
# Resampled maps have up to ENVMAP_MAX_FACTOR times the input's resolution per axis, and at most
# ENVMAP_MAX_WIDTH texels across: finer texels follow Mitsuba's bilinear interpolation closer.
ENVMAP_MAX_WIDTH, ENVMAP_MAX_FACTOR = 4096, 8


def read_emitter(plugin, reader):
    kind = plugin.type
    index = len(reader.out.scene["lights"])
    if kind == "area":
        raise plugin.error("an area emitter belongs inside a <shape>")
    if kind not in EMITTERS:
        raise plugin.error(f"unsupported emitter '{kind}' (supported: {', '.join(EMITTERS)}, and area in shapes)")
    warnings_ = reader.out.warnings
    if kind == "point":
        matrix = plugin.transform("to_world")
        position = plugin.point("position")
        if matrix is not None and position is not None:
            raise plugin.error("give either position or to_world")
        position = matrix[:3, 3] if matrix is not None else (np.zeros(3) if position is None else position)
        light = {"type": "point", "position": position.tolist(),
                 "intensity": plugin.color("intensity", 1.0, warnings_, emitter=True).tolist()}
    elif kind == "spot":
        light = _read_spot(plugin, warnings_)
    elif kind == "directional":
        matrix = plugin.transform("to_world")
        direction = plugin.point("direction")
        if matrix is not None and direction is not None:
            raise plugin.error("give either direction or to_world")
        direction = (matrix[:3, :3] @ [0.0, 0.0, 1.0] if matrix is not None
                     else np.array([0.0, 0.0, 1.0]) if direction is None else direction)
        light = {"type": "directional", "direction": direction.tolist(),
                 "irradiance": plugin.color("irradiance", 1.0, warnings_, emitter=True).tolist()}
    elif any(light["type"] == "environment" for light in reader.out.scene["lights"]):
        raise plugin.error("only one environment emitter (constant or envmap) per scene, as in Mitsuba")
    elif kind == "constant":
        light = {"type": "environment", "radiance": plugin.color("radiance", 1.0, warnings_, emitter=True).tolist()}
    else:
        light = _read_envmap(plugin, reader)
    plugin.finish()
    reader.out.scene["lights"].append(light)
    reader.note(plugin, f"lights[{index}]", _describe_light(light))


def read_area_emitter(plugin, reader):
    if plugin.type != "area":
        raise plugin.error(f"only 'area' emitters can be attached to shapes, got '{plugin.type}'")
    radiance = color_or_texture(plugin, "radiance", 1.0, reader, emitter=True)
    plugin.finish()
    return radiance


def _read_spot(plugin, warnings_):
    """spot: it shines from to_world's origin along its +z, within cutoff_angle degrees (Mitsuba
    normalises the local direction, so a uniform scale changes nothing)."""
    matrix = plugin.transform("to_world")
    matrix = np.eye(4) if matrix is None else matrix
    if rotation_scale(matrix) is None:
        raise plugin.error("a spot's to_world must be a rotation, a uniform scale and a translation")
    if plugin.has("texture"):
        raise plugin.error("spot textures are not supported")
    cutoff = plugin.number("cutoff_angle", 20.0)
    axis = matrix[:3, :3] @ [0.0, 0.0, 1.0]
    return {"type": "spot", "position": matrix[:3, 3].tolist(), "direction": (axis / np.linalg.norm(axis)).tolist(),
            "intensity": plugin.color("intensity", 1.0, warnings_, emitter=True).tolist(),
            "cutoff_angle": cutoff, "beam_width": plugin.number("beam_width", 0.75 * cutoff)}


def _describe_light(light):
    if light["type"] == "point":
        return f"point at {fmt(light['position'])}, intensity {fmt(light['intensity'])}"
    if light["type"] == "spot":
        return (f"spot at {fmt(light['position'])} towards {fmt(light['direction'])}, intensity "
                f"{fmt(light['intensity'])}, cutoff {light['cutoff_angle']:g} deg, beam {light['beam_width']:g} deg")
    if light["type"] == "directional":
        return f"directional towards {fmt(light['direction'])}, irradiance {fmt(light['irradiance'])}"
    if "image" in light:
        height, width, _ = light["image"].shape
        return f"environment image {width} x {height}"
    return f"constant environment {fmt(light['radiance'])}"


def _read_envmap(plugin, reader):
    """envmap: Mitsuba looks its lat-long map up bilinearly (texel centres at u = (i + 0.5) / W
    from -z towards +x, rows at v = j / (H - 1) from +y), after to_world's inverse rotation;
    clrender's map is constant per texel, +y up, centre looking down -z. The map is resampled
    into clrender's convention at up to 8 times its resolution (ENVMAP_MAX_*), each texel the
    solid-angle weighted mean of 2 x 2 bilinear lookups (a warning says so)."""
    path = plugin.file("filename", reader.files)
    try:
        image = load_image(path)
    except FileError as e:
        raise plugin.error(e.message) from None
    if image.shape[0] < 3 or image.shape[1] < 2:
        raise plugin.error("an environment map needs at least 2 x 3 pixels")
    scale = plugin.number("scale", 1.0)
    matrix = plugin.transform("to_world")
    rotation = np.eye(3)
    if matrix is not None:
        if not is_rigid(matrix):
            raise plugin.error("an envmap's to_world must be a rotation")
        rotation = matrix[:3, :3]
    plugin.accept("mis_compensation")   # a sampling choice: the same image
    height, width = image.shape[:2]
    factor = int(np.clip(ENVMAP_MAX_WIDTH // width, 1, ENVMAP_MAX_FACTOR))
    resampled = _stored_resample(image, rotation, factor * width, factor * height)
    resampled *= np.float32(scale)
    reader.warn(f"{plugin.element.where()}: Mitsuba interpolates the {width} x {height} map "
                f"bilinearly; resampled to {factor * width} x {factor * height} constant texels"
                + (" (rotated by to_world)" if matrix is not None else ""))
    return {"type": "environment", "image": resampled}


def _stored_resample(image, rotation, width, height):
    """resample_envmap, kept on disk (disk_cache.py) under the image's texels, the rotation, the
    size, this module's code and numpy's version: it took 0.6 s a start for a 512 x 256 map turned
    about y, 3.5 s for one that is not (the general path)."""
    image = np.ascontiguousarray(image, dtype=np.float32)
    entry = disk_cache.key("envmap", image.shape, hashlib.sha256(image).hexdigest(),
                           np.asarray(rotation, np.float64).tobytes(), width, height, _code_hash(), np.__version__)
    shape = (height, width, image.shape[2])
    stored = disk_cache.load("envmaps", entry, shape)
    if stored is not None:
        return stored
    resampled = resample_envmap(image, rotation, width, height)
    disk_cache.store("envmaps", entry, resampled)
    return resampled


@functools.cache
def _code_hash():
    return hashlib.sha256(Path(__file__).read_bytes()).hexdigest()


def mitsuba_envmap_lookup(image, directions):
    """Mitsuba's envmap value in local directions (N, 3): bilinear, periodic in u (see
    _read_envmap for the mapping)."""
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    return np.moveaxis(_bilinear(_planes(image), image.shape[:2], d[:, 0], d[:, 1], d[:, 2]), 0, -1)


def _planes(image):
    """An H x W x C image as C contiguous planes of H * W texels: lookups gather one plane at a
    time (numpy's loops over 3 interleaved channels are slower)."""
    return np.ascontiguousarray(np.moveaxis(image, 2, 0)).reshape(image.shape[2], -1)


def _bilinear(planes, size, x, y, z):
    """Mitsuba's bilinear envmap lookup in the unit directions (x, y, z) (arrays of one shape),
    from the C planes (C, H * W) of its H x W image: (C, *x.shape)."""
    height, width = size
    left, right, to_right = _columns(x, z, width)
    upper, to_lower = _rows(y, height)
    upper, lower = upper * width, (upper + 1) * width
    value = np.zeros((len(planes),) + x.shape, np.result_type(planes, to_right, to_lower))
    for index, weight in ((upper + left, (1 - to_lower) * (1 - to_right)), (upper + right, (1 - to_lower) * to_right),
                          (lower + left, to_lower * (1 - to_right)), (lower + right, to_lower * to_right)):
        for plane, channel in zip(planes, value):
            channel += np.take(plane, index) * weight
    return value


def _columns(x, z, width):
    """(left column, right column, weight of the right) of Mitsuba's lookup at directions whose
    x and z (any positive multiple) are given: texel centres at u = (i + 1/2) / W, u =
    atan2(x, -z) / 2 pi; past the last centre the first is interpolated again."""
    u = np.arctan2(x, -z) * np.float32(1 / (2 * np.pi)) - np.float32(0.5 / width)
    column = (u - np.floor(u)) * width
    left = np.minimum(np.floor(column), width - 1)
    return left.astype(np.int64), np.where(left == width - 1, 0, left + 1).astype(np.int64), column - left


def _rows(y, height):
    """(upper row, weight of the row below) of Mitsuba's lookup at unit directions with this y:
    rows at v = j / (H - 1) from +y."""
    row = np.arccos(np.clip(y, -1, 1)) * np.float32((height - 1) / np.pi)
    upper = np.minimum(np.floor(row), height - 2)
    return upper.astype(np.int64), row - upper


def resample_envmap(image, rotation, width, height):
    """clrender's (height, width, C) float32 lat-long map of Mitsuba's envmap `image` turned by
    `rotation` (its to_world): texel (j, i) covers u in [i, i + 1) / width (direction
    (sin(2 pi (u - 0.5)) sin(theta), cos(theta), -cos(2 pi (u - 0.5)) sin(theta))) and theta
    in [j, j + 1) pi / height. Its value is the sin(theta)-weighted mean of 2 x 2 lookups at the
    centres of its quarters (where the map keeps the image's resolution that is, in u, exactly
    the texel's mean of the interpolation, which is linear between the image's texel centres;
    one lookup at the centre of finer texels is 3-4 times further off the mean at a sharp
    texel). Rotations about y (the usual ones) keep rows and columns apart: the lookups then
    separate into a pass along the rows and one along the columns."""
    offsets = np.array([0.25, 0.75])
    phi = 2 * np.pi * ((np.arange(width)[:, None] + offsets) / width - 0.5)          # (width, 2)
    theta = (np.arange(height)[:, None] + offsets) / height * np.pi                  # (height, 2)
    rotation = np.asarray(rotation, dtype=np.float64)
    about_y = np.abs(np.abs(rotation[1, 1]) - 1) < 1e-9
    resample = _resample_about_y if about_y else _resample_rotated
    return resample(np.asarray(image, dtype=np.float32), rotation, phi, theta)


def _resample_about_y(image, rotation, phi, theta):
    """resample_envmap for a rotation that keeps the y axis (up to its sign): a lookup's column
    depends on phi only, its row on theta only, so the map is filtered along the rows, then along
    the columns, each output value a weighted sum of 4 taps (2 lookups x 2 neighbours)."""
    in_height, in_width = image.shape[:2]
    sin_phi, cos_phi = np.sin(phi), np.cos(phi)
    # rotation^T applied to (sin phi, ., -cos phi): x and z of the local direction (sin(theta) > 0 cancels).
    left, right, to_right = _columns(rotation[0, 0] * sin_phi - rotation[2, 0] * cos_phi,
                                     rotation[0, 2] * sin_phi - rotation[2, 2] * cos_phi, in_width)
    column_taps = np.concatenate([left, right], axis=1), np.concatenate([1 - to_right, to_right], axis=1) / 2
    upper, to_lower = _rows(np.sign(rotation[1, 1]) * np.cos(theta), in_height)
    weight = np.sin(theta) / np.sin(theta).sum(axis=1, keepdims=True)
    row_taps = np.concatenate([upper, upper + 1], axis=1), np.concatenate([weight * (1 - to_lower), weight * to_lower], axis=1)
    across = _taps(image, *column_taps, axis=1)   # each image row resampled along u
    return _taps(across, *row_taps, axis=0)


def _taps(source, indices, weights, axis):
    """Along `axis` (0 or 1) of the 3D array `source`, output k = sum over t of
    weights[k, t] * source[indices[k, t]]; float32, computed in bands of rows."""
    shape = list(source.shape)
    shape[axis] = len(indices)
    out = np.zeros(shape, np.float32)
    weights = weights.astype(np.float32)
    band = max(1, (1 << 20) // (shape[1] * shape[2]))
    for first in range(0, shape[0], band):
        rows = slice(first, first + band)
        if axis == 0:
            part, taps, factors = source, indices[rows], weights[rows, :, None, None]
        else:
            part, taps, factors = source[rows], indices, weights[None, :, :, None]
        for t in range(indices.shape[1]):
            out[rows] += np.take(part, taps[:, t], axis=axis) * np.take(factors, t, axis=axis + 1)
    return out


def _resample_rotated(image, rotation, phi, theta):
    """resample_envmap for any rotation: every lookup on its own, a band of rows at a time
    (bounded temporaries)."""
    height, width = len(theta), len(phi)
    planes = _planes(image)
    rotation = rotation.astype(np.float32)
    weight = (np.sin(theta) / np.sin(theta).sum(axis=1, keepdims=True) / phi.shape[1]).astype(np.float32)
    out = np.zeros((len(planes), height, width), np.float32)
    band = max(1, (1 << 19) // width)
    for first in range(0, height, band):
        rows = slice(first, first + band)
        for row_sample in range(theta.shape[1]):
            sin_theta = np.sin(theta[rows, row_sample, None]).astype(np.float32)
            cos_theta = np.cos(theta[rows, row_sample, None]).astype(np.float32)
            for column_sample in range(phi.shape[1]):
                sin_phi = np.sin(phi[:, column_sample]).astype(np.float32)
                cos_phi = np.cos(phi[:, column_sample]).astype(np.float32)
                world = (sin_phi * sin_theta, np.broadcast_to(cos_theta, (len(sin_theta), width)), -cos_phi * sin_theta)
                local = [sum(world[k] * rotation[k, axis] for k in range(3)) for axis in range(3)]   # rotation^T world
                out[:, rows] += _bilinear(planes, image.shape[:2], *local) * weight[rows, row_sample, None]
    return np.ascontiguousarray(np.moveaxis(out, 0, 2))
