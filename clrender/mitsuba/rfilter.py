"""Reconstruction filters (a film's `rfilter`).

| plugin | clrender |
|---|---|
| `box` | exact: each sample counts in its own pixel, uniform in it |
| any other (Mitsuba's default: `gaussian`) | approximated by the box filter, a warning (the image slightly sharper, its averages the same) |

Filter parameters are not read.
"""
# What the warning says of any other filter.
BOX_APPROXIMATION = ("approximated by clrender's box filter (each sample counts in its own pixel "
                     "only): slightly sharper")


def read_rfilter(plugin, reader):
    if plugin.type != "box":
        reader.warn(f"{plugin.element.where()}: reconstruction filter '{plugin.type}' {BOX_APPROXIMATION}")
