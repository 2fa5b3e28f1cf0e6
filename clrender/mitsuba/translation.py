"""The translation of a Mitsuba scene: the driver that reads the scene's plugins into the scene
dict of docs/scene-format.md, and its validation by `load_scene_dict`.

| top-level element | read by |
|---|---|
| `<integrator>` (at most one; none: `path`) | integrator.py |
| `<sensor>` (exactly one) | sensor.py (with film.py, rfilter.py, sampler.py) |
| `<shape>` | shape.py (with bsdf.py, emitter.py's area emitters, medium.py) |
| `<emitter>` | emitter.py |
| `<bsdf>`, `<medium>` | where shapes and sensors reference them (unreferenced: no effect, as in Mitsuba) |
| `<film>`, `<sampler>`, `<rfilter>`, `<phase>`, `<volume>`, `<texture>` | where referenced: they need an `id` |
"""
from dataclasses import dataclass, field
from pathlib import Path

from .. import limits
from ..errors import ArgumentError, SceneError
from ..loader import LoadedScene
from ..origins import Origins, located
from ..scene import load_scene_dict
from .emitter import read_emitter
from .integrator import check_direct_delta_lights, read_integrator
from .medium import check_media_nesting
from .plugin import Plugin
from .sensor import read_sensor
from .shape import read_shape
from .xml import OBJECT_TAGS, Files, MitsubaXmlError, MitsubaXmlWarning, check_version, collect_ids, expand, parse_xml

# The plugins at the scene's top level, each read by its kind's read_<kind>(plugin, reader), kind
# after kind in this order: the integrator decides whether media count, the sensor makes the
# render settings. A plugin's nested objects are read by its own kind's module.
SCENE_PLUGINS = {"integrator": read_integrator, "sensor": read_sensor, "shape": read_shape,
                 "emitter": read_emitter}
# Top-level kinds that only matter where referenced, so they must have an id.
REFERENCED_ONLY = ("film", "sampler", "rfilter", "phase", "volume", "texture")


@dataclass
class Translation:
    """A Mitsuba scene as a scene dict, with what the reader noticed along the way."""
    scene: dict
    warnings: list = field(default_factory=list)   # approximations, one message each
    notes: list = field(default_factory=list)      # 'element -> scene field: summary', for info
    origins: dict = field(default_factory=dict)    # scene dict path ('shapes[2]') -> element place


class Reader:
    """State of one translation: the scene dict being built and the shared objects."""

    def __init__(self, ids, files):
        self.ids = ids
        self.files = files
        self.out = Translation({"materials": [], "shapes": [], "lights": [], "media": [], "textures": []})
        self.material_names = {}   # (id() of the BSDF element or None, emission or None) -> name
        self.texture_names = {}    # id() of the texture element -> name
        self.medium_names = {}     # id() of the medium element -> name
        self.integrator = "path"    # the type of the integrator that renders the colour
        self.ignore_media = False  # Mitsuba's `path`, `ptracer` and `direct` render without media

    def warn(self, message):
        self.out.warnings.append(message)

    def note(self, plugin, path, summary):
        self.out.notes.append(f"{plugin.element.where()} -> {path}: {summary}")
        self.out.origins[path] = plugin.element.where()


def read_scene(path, parameters=None):
    """Parse and translate a Mitsuba 3 XML file; `parameters` (name -> value strings) override
    its <default> values, like Mitsuba's -D. Returns a Translation (not yet validated)."""
    if parameters is not None and not (isinstance(parameters, dict) and all(isinstance(k, str) for k in parameters)):
        raise ArgumentError("parameters", "must be a dict of parameter names to values, "
                                          f"got {limits.show(parameters)}")
    path = Path(path)
    root = parse_xml(path)
    check_version(root)
    files = Files(path.parent.resolve())
    elements = expand(root, {k: str(v) for k, v in (parameters or {}).items()}, files)
    ids = collect_ids(elements)
    reader = Reader(ids, files)
    reader.out.origins[""] = root.where()   # what no element accounts for: the file's <scene>
    by_tag = {}
    for element in elements:
        by_tag.setdefault(element.tag, []).append(element)
        if element.tag not in OBJECT_TAGS:
            raise element.error(f"unexpected element <{element.tag}> in <scene>")
    for tag in REFERENCED_ONLY:
        for element in by_tag.get(tag, []):
            if "id" not in element.attrs:
                raise element.error(f"a top-level <{tag}> must have an id (and be referenced)")
    integrators, sensors = by_tag.get("integrator", []), by_tag.get("sensor", [])
    if len(integrators) > 1:
        raise integrators[1].error("only one <integrator> is allowed")
    if len(sensors) != 1:
        raise (sensors[1].error("clrender renders one sensor: keep a single <sensor>") if sensors
               else root.error("the scene has no <sensor> (clrender needs a camera)"))
    if not integrators:
        read_integrator(None, reader)
    for tag, read in SCENE_PLUGINS.items():
        for element in by_tag.get(tag, []):
            read(Plugin(element, ids), reader)
    if integrators:
        check_direct_delta_lights(reader, integrators[0])
    return reader.out


def scene_from_translation(translation):
    """Validate a Translation's dict with load_scene_dict; errors name the XML element."""
    origins = Origins(translation.origins, MitsubaXmlError)
    try:
        scene = load_scene_dict(translation.scene)
    except SceneError as e:
        raise located(e, origins) from None
    check_media_nesting(scene, translation)
    scene.origins = origins
    return scene


def read_scene_file(path, parameters=None):
    """A Mitsuba 3 XML scene file as a LoadedScene (clrender.loader's reader of `.xml`):
    validated like a JSON scene, a MitsubaXmlWarning per approximation."""
    translation = read_scene(path, parameters)
    scene = scene_from_translation(translation)
    scene.path = Path(path)
    return LoadedScene(scene, [MitsubaXmlWarning(message) for message in translation.warnings],
                       translation.notes)
