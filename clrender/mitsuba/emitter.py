"""Emitters: lights, the environment, and the emission of shapes.

| plugin | parameter (Mitsuba's default) | clrender |
|---|---|---|
| `area` (in a shape) | `radiance` (1) | the shape's material `emission` (front side only in both) |
| `point` | `intensity` (1), `position` or `to_world` | `point` light |
| `spot` | `intensity` (1), `cutoff_angle` (20), `beam_width` (3/4 of the cutoff), `to_world` (a rotation, uniform scale and translation: it shines along +z from its origin) | `spot` light; a `texture` is an error |
| `directional` | `irradiance` (1), `direction` or to_world(+z) | `directional` light |
| `constant` | `radiance` (1) | constant `environment` |
| `envmap` | `filename`, `scale` (1), `to_world` (a rotation); `mis_compensation` accepted | image `environment` with Mitsuba's `lookup` and its `transform` |

One environment per scene, as in Mitsuba.
"""
import numpy as np

from ..errors import FileError
from ..image import load_image
from .texture import color_or_texture
from .transforms import is_rigid, matrix_rows, rotation_scale
from .values import fmt

EMITTERS = ("point", "spot", "directional", "constant", "envmap")


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
    from -z towards +x, rows at v = j / (H - 1) from +y), after to_world's inverse rotation; so
    does the kernel with the environment's lookup "mitsuba" (kernels/lights.h), the map at its
    own resolution."""
    path = plugin.file("filename", reader.files)
    try:
        image = load_image(path)
    except FileError as e:
        raise plugin.error(e.message) from None
    if image.shape[0] < 3 or image.shape[1] < 2:
        raise plugin.error("an environment map needs at least 2 x 3 pixels")
    scale = plugin.number("scale", 1.0)
    matrix = plugin.transform("to_world")
    plugin.accept("mis_compensation")   # a sampling choice: the same image
    light = {"type": "environment", "image": image, "scale": scale, "lookup": "mitsuba"}
    if matrix is not None:
        if not is_rigid(matrix):
            raise plugin.error("an envmap's to_world must be a rotation")
        rotation = np.eye(4)
        rotation[:3, :3] = matrix[:3, :3]   # directions only: a translation changes nothing
        light["transform"] = {"matrix": matrix_rows(rotation)}
    return light
