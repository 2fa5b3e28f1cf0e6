"""Integrators.

| plugin | parameter (Mitsuba's default) | clrender |
|---|---|---|
| `path`, `volpath`, `volpathmis` | | one integrator (next-event estimation + MIS, media when present); `path` ignores media, as Mitsuba's |
| | `max_depth` (-1) | `render.max_depth`; -1 (unbounded) and values above the format's limit become MAX_DEPTH |
| | `rr_depth` (5) | `render.rr_depth`: `path` n is clrender's n, `volpath(mis)` n is n + 1 (at least 1) |
| | `hide_emitters` (false) | `render.hide_emitters`: camera rays pass through emitting shapes and escape to black |
| `ptracer` | `max_depth`, `rr_depth`, `hide_emitters`; `samples_per_pass` accepted | rendered as `path` (a warning: the image path tracing estimates, which Mitsuba's light tracer does not reach through smooth mirrors and glass) |
| `direct` | `shading_samples` (1), `emitter_samples`, `bsdf_samples` (both `shading_samples`), `hide_emitters` | `render.integrator` "direct" and its sample counts; ignores media, as Mitsuba's |
| `moment` | one nested integrator | that integrator, and the `variance` AOV (`render.aovs`) |
| `aov` | `aovs` ("name:type, ..."), one nested integrator | that integrator, and clrender's AOVs for the types (AOV_TYPES; warnings say how they differ) |
| none | | `path`, as Mitsuba's default |
"""
from .. import limits
from ..aovs import AOV_NAMES

RENDERING = ("path", "volpath", "volpathmis", "ptracer", "direct")
WRAPPERS = ("moment", "aov")
INTEGRATORS = RENDERING + WRAPPERS
MEDIA_FREE = ("path", "ptracer", "direct")   # Mitsuba's render surfaces only
MAX_DEPTH = limits.MAX_DEPTH   # the format's limit; Mitsuba's -1 (unbounded) maps here: roulette ends paths first

# Mitsuba's aov types -> (clrender's AOV, how it differs). Mitsuba's AOVs are the first surface
# hit by each camera sample, averaged over the pixel's samples (0 where nothing is hit).
AOV_TYPES = {
    "albedo": ("albedo", "followed through smooth mirrors and glass to the first rough surface"),
    "sh_normal": ("normal", "facing the camera, followed through smooth mirrors and glass"),
    "geo_normal": ("normal", "the shading normal, facing the camera, followed through smooth mirrors and glass"),
    "depth": ("depth", "the planar depth (along the view axis) at the pixel centre, inf where nothing is "
                       "hit; Mitsuba's is the distance along each ray, averaged, 0 there"),
    "shape_index": ("object_id", "the shape's index among clrender's shapes at the pixel centre, -1 where "
                                 "nothing is hit"),
}


def read_integrator(plugin, reader):
    """The render settings of the scene's integrator (None: the scene has none, Mitsuba's path)."""
    render = {}
    reader.out.scene["render"] = render
    if plugin is None:   # Mitsuba's default: path, max_depth -1, rr_depth 5
        render.update(max_depth=MAX_DEPTH, rr_depth=5)
        reader.integrator = "path"
        reader.ignore_media = True
        return
    while plugin.type in WRAPPERS:
        plugin = _read_wrapper(plugin, reader, render)
    if plugin.type not in RENDERING:
        raise plugin.error(f"unsupported integrator '{plugin.type}' (supported: {', '.join(INTEGRATORS)}); "
                           "Mitsuba too renders it only with a plugin of that name")
    reader.integrator = plugin.type
    reader.ignore_media = plugin.type in MEDIA_FREE
    if plugin.type == "direct":
        _read_direct(plugin, render)
    else:
        _read_path(plugin, render)
    if plugin.boolean("hide_emitters", False):
        render["hide_emitters"] = True
    if plugin.type == "ptracer":
        plugin.accept("samples_per_pass")   # how the work is split
        reader.warn(f"{plugin.element.where()}: rendered by path tracing, which estimates the same image except "
                    "where the camera sees smooth mirrors and glass: Mitsuba's light tracer shows black there "
                    "(and with hide_emitters emitting shapes as their BSDF, where clrender sees through them)")
    plugin.finish()
    reader.note(plugin, "render", _describe(render))


def check_direct_delta_lights(reader, integrator):
    """Mitsuba 3.9's direct integrator weighs each of its emitter_samples samples of a point,
    spot or directional light by 1, not 1 / emitter_samples: they come out emitter_samples times
    too bright (measured against its path integrator). clrender renders them once: a warning."""
    render = reader.out.scene["render"]
    delta = [light for light in reader.out.scene["lights"] if light["type"] in ("point", "spot", "directional")]
    if render.get("integrator") == "direct" and render["emitter_samples"] > 1 and delta:
        reader.warn(f"{integrator.where()}: Mitsuba 3.9 renders point, spot and directional lights "
                    f"emitter_samples = {render['emitter_samples']} times too bright with this integrator; "
                    "clrender renders them as they are")


def _read_path(plugin, render):
    """max_depth (-1: unbounded) and rr_depth of path/volpath/volpathmis/ptracer. Roulette starts
    after vertex rr_depth in `path` but after vertex rr_depth + 1 in `volpath(mis)` (which tests
    depth > rr_depth before counting the next vertex)."""
    max_depth = plugin.integer("max_depth", -1)
    if max_depth == 0:
        raise plugin.error("max_depth 0 renders a black image")
    if max_depth < -1:
        raise plugin.error(f"max_depth must be -1 (unbounded) or >= 1, got {max_depth}")
    rr_depth = plugin.integer("rr_depth", 5)
    if rr_depth < 0:
        raise plugin.error(f"rr_depth must be >= 0, got {rr_depth}")
    render["max_depth"] = MAX_DEPTH if max_depth == -1 else min(max_depth, MAX_DEPTH)
    render["rr_depth"] = max(rr_depth + (plugin.type in ("volpath", "volpathmis")), 1)


def _read_direct(plugin, render):
    """Mitsuba's direct integrator: emitter_samples and bsdf_samples default to shading_samples."""
    shading = _sample_count(plugin, "shading_samples", 1)
    render["integrator"] = "direct"
    render["emitter_samples"] = _sample_count(plugin, "emitter_samples", shading)
    render["bsdf_samples"] = _sample_count(plugin, "bsdf_samples", shading)
    if render["emitter_samples"] + render["bsdf_samples"] == 0:
        raise plugin.error("emitter_samples and bsdf_samples are both 0 (Mitsuba refuses it too)")


def _sample_count(plugin, name, default):
    count = plugin.integer(name, default)
    if not 0 <= count <= limits.MAX_SHADING_SAMPLES:
        raise plugin.error(f"{name} must be in 0..{limits.MAX_SHADING_SAMPLES}, got {count}")
    return count


def _read_wrapper(plugin, reader, render):
    """The AOVs of a moment or aov integrator (added to render.aovs); returns its nested
    integrator, which renders the colour."""
    aovs = ["variance"] if plugin.type == "moment" else _read_aov_types(plugin, reader)
    render["aovs"] = [name for name in AOV_NAMES if name in aovs or name in render.get("aovs", [])]
    nested = plugin.nested("integrator")
    if len(nested) != 1:
        raise plugin.error(f"clrender renders the colour of one nested integrator, this {plugin.type} "
                           f"integrator has {len(nested)}")
    plugin.finish()
    reader.note(plugin, "render.aovs", ", ".join(aovs))
    return nested[0]


def _read_aov_types(plugin, reader):
    """clrender's AOVs for the `aovs` string ("name:type, ..."); the names are Mitsuba's channel
    prefixes, the layers keep clrender's names."""
    text = plugin.string("aovs", "")
    aovs = []
    for item in (part.strip() for part in text.split(",") if part.strip()):
        name, _, kind = item.rpartition(":")
        if not name or kind not in AOV_TYPES:
            raise plugin.error(f"AOV {limits.show(item)}: clrender writes the types {', '.join(AOV_TYPES)} "
                               "(as name:type)")
        ours, difference = AOV_TYPES[kind]
        reader.warn(f"{plugin.element.where()}: AOV '{item}' is written as clrender's '{ours}' layer: {difference}")
        aovs.append(ours)
    if not aovs:
        raise plugin.error("the aov integrator needs aovs=\"name:type, ...\"")
    return aovs


def _describe(render):
    if render.get("integrator") == "direct":
        text = f"direct, {render['emitter_samples']} emitter and {render['bsdf_samples']} BSDF samples"
    else:
        text = f"max_depth {render['max_depth']}, rr_depth {render['rr_depth']}"
    return text + (", emitters hidden from the camera" if render.get("hide_emitters") else "")
