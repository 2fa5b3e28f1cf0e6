"""Integrators.

| plugin | parameter (Mitsuba's default) | clrender |
|---|---|---|
| `path`, `volpath`, `volpathmis` | | one integrator (next-event estimation + MIS, media when present); `path` ignores media, as Mitsuba's |
| | `max_depth` (-1) | `render.max_depth`; -1 (unbounded) and values above the format's limit become MAX_DEPTH |
| | `rr_depth` (5) | `render.rr_depth`: `path` n is clrender's n, `volpath(mis)` n is n + 1 (at least 1) |
| | `hide_emitters` (false) | `render.hide_environment` |
| none | | `path`, as Mitsuba's default |
"""
from .. import limits

INTEGRATORS = ("path", "volpath", "volpathmis")
MAX_DEPTH = limits.MAX_DEPTH   # the format's limit; Mitsuba's -1 (unbounded) maps here: roulette ends paths first


def read_integrator(plugin, reader):
    """max_depth (-1: unbounded), rr_depth and hide_emitters of path/volpath/volpathmis; None:
    the scene has no integrator. Roulette starts after vertex rr_depth in `path` but after vertex
    rr_depth + 1 in `volpath(mis)` (which tests depth > rr_depth before counting the next vertex)."""
    render = {}
    reader.out.scene["render"] = render
    if plugin is None:   # Mitsuba's default: path, max_depth -1, rr_depth 5
        render.update(max_depth=MAX_DEPTH, rr_depth=5)
        reader.ignore_media = True
        return
    if plugin.type not in INTEGRATORS:
        raise plugin.error(f"unsupported integrator '{plugin.type}' (supported: {', '.join(INTEGRATORS)})")
    max_depth = plugin.integer("max_depth", -1)
    if max_depth == 0:
        raise plugin.error("max_depth 0 renders a black image")
    if max_depth < -1:
        raise plugin.error(f"max_depth must be -1 (unbounded) or >= 1, got {max_depth}")
    rr_depth = plugin.integer("rr_depth", 5)
    if rr_depth < 0:
        raise plugin.error(f"rr_depth must be >= 0, got {rr_depth}")
    hide = plugin.boolean("hide_emitters", False)
    plugin.finish()
    render["max_depth"] = MAX_DEPTH if max_depth == -1 else min(max_depth, MAX_DEPTH)
    render["rr_depth"] = max(rr_depth + (plugin.type != "path"), 1)
    if hide:
        render["hide_environment"] = True
    reader.ignore_media = plugin.type == "path"
    reader.note(plugin, "render", f"max_depth {render['max_depth']}, rr_depth {render['rr_depth']}"
                + (", environment hidden from the camera" if hide else ""))
