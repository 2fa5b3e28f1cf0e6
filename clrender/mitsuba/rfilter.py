"""Reconstruction filters (a film's `rfilter`): `camera.filter` (clrender/filters.py).

| plugin | parameter (Mitsuba's default) | clrender |
|---|---|---|
| `box` | | `box`: each sample counts in its own pixel, uniform in it |
| `gaussian` (the default, also without an rfilter or a film) | `stddev` (0.5) | `gaussian`, exact |
| `tent` | `radius` (1) | `tent`, exact |
| any other (`mitchell`, `catmullrom`, `lanczos`) | | approximated by the box filter, a warning (the image slightly sharper, its averages the same) |
"""
from ..scene import MAX_FILTER_RADIUS, MIN_FILTER_RADIUS

# Mitsuba's filter when a film names none.
DEFAULT_FILTER = {"type": "gaussian", "stddev": 0.5}


def read_rfilter(plugin, reader):
    """camera.filter of the rfilter `plugin`; None: Mitsuba's default."""
    if plugin is None:
        return dict(DEFAULT_FILTER)
    if plugin.type == "gaussian":
        pixel_filter = {"type": "gaussian", "stddev": _width(plugin, "stddev", DEFAULT_FILTER["stddev"], 4)}
    elif plugin.type == "tent":
        pixel_filter = {"type": "tent", "radius": _width(plugin, "radius", 1.0, 1)}
    else:
        if plugin.type != "box":
            reader.warn(f"{plugin.element.where()}: reconstruction filter '{plugin.type}' approximated by "
                        "clrender's box filter (each sample counts in its own pixel only): slightly sharper")
        pixel_filter = {"type": "box"}
    plugin.finish()
    return pixel_filter


def _width(plugin, name, default, radii):
    """The parameter `name`, `radii` times which is the filter's radius, within clrender's range."""
    value = plugin.number(name, default)
    if not MIN_FILTER_RADIUS <= value * radii <= MAX_FILTER_RADIUS:
        raise plugin.error(f"{name} must be in [{MIN_FILTER_RADIUS / radii:g}, {MAX_FILTER_RADIUS / radii:g}] "
                           f"pixels, got {value:g}")
    return value
