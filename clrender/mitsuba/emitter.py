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
import numpy as np

from ..image import load_image
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
    radiance = plugin.color("radiance", 1.0, reader.out.warnings, emitter=True)
    plugin.finish()
    return [float(v) for v in radiance]


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
        image = load_image(path).astype(np.float64)
    except Exception as e:   # OpenEXR and imageio raise many types for malformed files
        raise plugin.error(f"cannot load image {path}: {e}") from None
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
    resampled = resample_envmap(image, rotation, factor * width, factor * height) * scale
    reader.warn(f"{plugin.element.where()}: Mitsuba interpolates the {width} x {height} map "
                f"bilinearly; resampled to {factor * width} x {factor * height} constant texels"
                + (" (rotated by to_world)" if matrix is not None else ""))
    return {"type": "environment", "image": resampled.astype(np.float32)}


def mitsuba_envmap_lookup(image, directions):
    """Mitsuba's envmap value in local directions (N, 3): bilinear, periodic in u (see
    _read_envmap for the mapping)."""
    height, width = image.shape[:2]
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    u = np.arctan2(d[:, 0], -d[:, 2]) / (2 * np.pi) - 0.5 / width
    u -= np.floor(u)
    v = np.arccos(np.clip(d[:, 1], -1, 1)) / np.pi
    x, y = u * width, v * (height - 1)
    x0 = np.minimum(np.floor(x).astype(int), width - 1)
    y0 = np.minimum(np.floor(y).astype(int), height - 2)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x1 = (x0 + 1) % width   # the padded column repeats the first
    return ((1 - fy) * ((1 - fx) * image[y0, x0] + fx * image[y0, x1])
            + fy * ((1 - fx) * image[y0 + 1, x0] + fx * image[y0 + 1, x1]))


def resample_envmap(image, rotation, width, height):
    """clrender's (height, width, 3) lat-long map of Mitsuba's envmap `image` turned by
    `rotation` (its to_world): texel (j, i) covers u in [i, i + 1) / width (direction
    (sin(2 pi (u - 0.5)) sin(theta), cos(theta), -cos(2 pi (u - 0.5)) sin(theta))) and theta
    in [j, j + 1) pi / height; its value is the sin(theta)-weighted mean of 2 x 2 lookups."""
    out = np.zeros((height, width, 3))
    rows_per_chunk = max(1, (1 << 20) // width)   # bounded temporaries for large maps
    for first in range(0, height, rows_per_chunk):
        rows = np.arange(first, min(first + rows_per_chunk, height))
        total = np.zeros((len(rows), width, 3))
        weight = np.zeros((len(rows), 1, 1))
        for dv in (0.25, 0.75):
            theta = (rows + dv) / height * np.pi
            sin_theta = np.sin(theta)[:, None, None]
            for du in (0.25, 0.75):
                phi = 2 * np.pi * ((np.arange(width) + du) / width - 0.5)
                t, p = np.meshgrid(theta, phi, indexing="ij")
                world = np.stack([np.sin(p) * np.sin(t), np.cos(t), -np.cos(p) * np.sin(t)], axis=-1)
                local = world.reshape(-1, 3) @ rotation   # rotation^T applied to each direction
                total += mitsuba_envmap_lookup(image, local).reshape(len(rows), width, 3) * sin_theta
                weight += sin_theta
        out[rows] = total / weight
    return out
