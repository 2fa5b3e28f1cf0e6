"""Textures: the scene's `textures`, and the parameters of other plugins that may be one.

| plugin | parameter (Mitsuba's default) | clrender texture |
|---|---|---|
| `bitmap` | `filename`; `filter_type` (bilinear, nearest); `wrap_mode` (repeat, mirror, clamp); `raw` (false: 8-bit images are sRGB-encoded) | `bitmap` (`file`, `filter`, `wrap`, `raw`) |
| `checkerboard` | `color0` (0.4), `color1` (0.2): constants | `checkerboard` |
| both | `to_uv` (a transform: its rows and columns x, y and translation act on uv) | `to_uv` |
| accepted | `accel` (a lookup's implementation, not its value) | |

A parameter that takes a texture (`<texture type="bitmap" name="reflectance">` or a `<ref>` to
one) becomes {"texture": NAME} in the material; each texture element becomes one scene texture,
however often it is referenced.
"""
import numpy as np

from .. import textures

TEXTURES = textures.KINDS


def read_texture(plugin, reader):
    """The name of the scene texture made from `plugin` (made once per element)."""
    key = id(plugin.element)
    if key in reader.texture_names:
        return reader.texture_names[key]
    kind = plugin.type
    if kind not in TEXTURES:
        raise plugin.error(f"unsupported texture '{kind}' (supported: {', '.join(TEXTURES)})")
    texture = {"type": kind}
    matrix = plugin.transform("to_uv")
    if matrix is not None:
        texture["to_uv"] = [[float(matrix[row, col]) for col in (0, 1, 3)] for row in (0, 1)]
    if kind == "bitmap":
        texture["file"] = str(plugin.file("filename", reader.files))
        texture["filter"] = _choice(plugin, "filter_type", "bilinear", textures.FILTERS)
        texture["wrap"] = _choice(plugin, "wrap_mode", "repeat", textures.WRAPS)
        texture["raw"] = plugin.boolean("raw", False)
        plugin.accept("accel")
    else:
        texture["color0"] = plugin.color("color0", 0.4, reader.out.warnings).tolist()
        texture["color1"] = plugin.color("color1", 0.2, reader.out.warnings).tolist()
    plugin.finish()
    names = {t["name"] for t in reader.out.scene["textures"]}
    base = plugin.id or f"{kind}_line{plugin.element.line}"
    name, suffix = base, 1
    while name in names:
        suffix += 1
        name = f"{base}_{suffix}"
    texture["name"] = name
    index = len(reader.out.scene["textures"])
    reader.out.scene["textures"].append(texture)
    reader.note(plugin, f"textures[{index}]", f"{kind} '{name}'")
    reader.texture_names[key] = name
    return name


def _choice(plugin, name, default, choices):
    value = plugin.string(name, default)
    if value not in choices:
        raise plugin.error(f"unknown {name} '{value}' (valid: {', '.join(choices)})")
    return value


def color_or_texture(plugin, name, default, reader, emitter=False):
    """Parameter `name` as an RGB list, or {"texture": NAME} when it is a texture."""
    texture = plugin.object(name, "texture") if _is_texture(plugin, name) else None
    if texture is not None:
        return {"texture": read_texture(texture, reader)}
    return plugin.color(name, default, reader.out.warnings, emitter=emitter).tolist()


def number_or_texture(plugin, name, default, reader):
    """Parameter `name` as a number, or {"texture": NAME} when it is a texture."""
    if _is_texture(plugin, name):
        return {"texture": read_texture(plugin.object(name, "texture"), reader)}
    return plugin.number(name, default)


def _is_texture(plugin, name):
    return plugin.has(name) and plugin.properties[name][0].tag == "texture"


def is_textured(value):
    """Whether a value returned by color_or_texture / number_or_texture names a texture."""
    return isinstance(value, dict)


def constant_color(value):
    """An RGB array of a constant parameter value (None for a texture)."""
    return None if is_textured(value) else np.asarray(value, float)
