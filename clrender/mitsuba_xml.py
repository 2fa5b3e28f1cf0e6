"""Mitsuba 3 XML scenes: read a `scene.xml` into the scene dict of docs/scene-format.md.

The XML is parsed with each element's file and line, `<include>`, `<default>`/`$name`, `<path>`
and `<ref>` are resolved, and one function per plugin kind (integrator, sensor, film, sampler,
bsdf, shape, emitter, medium, phase, volume) turns the elements into plain dicts. The result
goes through `load_scene_dict` like any JSON scene, so every check of the format applies; its
errors are reported at the XML element they came from. Anything outside the supported subset
is a MitsubaXmlError naming the element, its type and its line; the few unavoidable
approximations (docs/mitsuba-xml.md) are MitsubaXmlWarnings.

    scene = clrender.load_scene("scene.xml", parameters={"spp": "64"})
"""
import re
import warnings
import xml.parsers.expat
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import cie, limits, meshes
from .errors import ArgumentError, SceneError


class MitsubaXmlError(SceneError):
    """A Mitsuba XML scene that clrender cannot read; `where` is 'file.xml:LINE <tag type=...>'."""


class MitsubaXmlWarning(UserWarning):
    """A Mitsuba feature that clrender renders approximately (docs/mitsuba-xml.md)."""


# ============================================================================================
# XML with line numbers
# ============================================================================================
@dataclass
class Element:
    tag: str
    attrs: dict
    file: Path
    line: int
    children: list = field(default_factory=list)

    def where(self):
        kind = f" type='{self.attrs['type']}'" if "type" in self.attrs else ""
        name = f" name='{self.attrs['name']}'" if "name" in self.attrs else ""
        return f"{self.file.name}:{self.line} <{self.tag}{kind}{name}>"

    def error(self, message):
        return MitsubaXmlError(self.where(), message)


def parse_xml(path):
    """The root Element of an XML file."""
    from .scene import read_scene_bytes

    path = Path(path)
    data = read_scene_bytes(path, MitsubaXmlError)
    parser = xml.parsers.expat.ParserCreate()
    stack, roots = [], []

    def start(tag, attrs):
        if len(stack) >= MAX_NESTING:   # the translation walks the tree recursively
            raise MitsubaXmlError(f"{path.name}:{parser.CurrentLineNumber}",
                                  f"elements nested deeper than {MAX_NESTING}")
        element = Element(tag, dict(attrs), path, parser.CurrentLineNumber)
        (stack[-1].children if stack else roots).append(element)
        stack.append(element)

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda tag: stack.pop()
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as e:
        raise MitsubaXmlError(f"{path.name}:{e.lineno}", f"malformed XML: {xml.parsers.expat.ErrorString(e.code)}") from None
    return roots[0]


# ============================================================================================
# Pre-processing: version, <include>, <default> and $name, <path>
# ============================================================================================
PARAMETER_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")   # what $name may name (and -D set)
_PARAMETER = re.compile(r"\$(" + PARAMETER_NAME.pattern + ")")
MAX_INCLUDE_DEPTH = 16
MAX_NESTING = 100   # elements inside elements: real scenes need a handful


class _Files:
    """Relative file names resolve against the folder of the XML file that names them, then the
    main scene's folder, then folders added by <path> (Mitsuba's file resolver)."""

    def __init__(self, scene_dir):
        self.search = [scene_dir]

    def resolve(self, name, element):
        name = Path(name)
        if name.is_absolute():
            candidates = [name]
        else:
            candidates = [element.file.parent / name] + [folder / name for folder in self.search]
        for candidate in candidates:
            if candidate.is_file():
                return candidate.resolve()
        raise element.error(f"file not found: {name} (looked in: "
                            f"{', '.join(str(c.parent) for c in candidates)})")


def _check_version(root):
    if root.tag != "scene":
        raise root.error("the root element must be <scene>")
    version = root.attrs.get("version")
    if version is None:
        raise root.error("<scene> needs a version attribute (e.g. version=\"3.0.0\")")
    if version.split(".")[0] != "3":
        raise root.error(f"scene version {version}: only Mitsuba 3 scenes (version 3.x) are supported")


def _substitute(element, parameters):
    """A copy of `element` and its subtree with $name replaced in every attribute value."""
    def value(text):
        def replace(match):
            if match.group(1) not in parameters:
                raise element.error(f"undefined parameter ${match.group(1)} (give it a <default> "
                                    "or pass it, e.g. -D name=value)")
            return parameters[match.group(1)]
        return _PARAMETER.sub(replace, text)

    attrs = {key: value(text) for key, text in element.attrs.items()}
    copy = Element(element.tag, attrs, element.file, element.line)
    copy.children = [_substitute(child, parameters) for child in element.children]
    return copy


def _expand(root, parameters, files, depth=0):
    """The scene's top-level elements after includes, defaults and substitution, in order."""
    elements = []
    for child in root.children:
        if child.tag == "default":
            name, text = child.attrs.get("name"), child.attrs.get("value")
            if name is None or text is None:
                raise child.error("<default> needs name and value attributes")
            parameters.setdefault(name, text)
        elif child.tag == "include":
            child = _substitute(child, parameters)
            if depth >= MAX_INCLUDE_DEPTH:
                raise child.error(f"includes nested deeper than {MAX_INCLUDE_DEPTH} (a cycle?)")
            included = parse_xml(files.resolve(_attribute(child, "filename"), child))
            _check_version(included)
            elements += _expand(included, parameters, files, depth + 1)
        elif child.tag == "path":
            child = _substitute(child, parameters)
            folder = (child.file.parent / _attribute(child, "value")).resolve()
            if not folder.is_dir():
                raise child.error(f"folder not found: {folder}")
            files.search.append(folder)
        else:
            elements.append(_substitute(child, parameters))
    return elements


def _attribute(element, name):
    if name not in element.attrs:
        raise element.error(f"missing attribute '{name}'")
    return element.attrs[name]


def _collect_ids(elements):
    ids = {}

    def visit(element):
        if "id" in element.attrs and element.tag in OBJECT_TAGS:
            if element.attrs["id"] in ids:
                first = ids[element.attrs["id"]]
                raise element.error(f"duplicate id '{element.attrs['id']}' (first at line {first.line})")
            ids[element.attrs["id"]] = element
        for child in element.children:
            visit(child)

    for element in elements:
        visit(element)
    return ids


# ============================================================================================
# Plugins and their properties
# ============================================================================================
PROPERTY_TAGS = ("float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector",
                 "transform")
OBJECT_TAGS = ("integrator", "sensor", "film", "sampler", "rfilter", "bsdf", "shape", "emitter",
               "medium", "phase", "volume", "texture")


class Plugin:
    """An object element (`<bsdf type="diffuse">`...): its properties by name and its unnamed
    nested objects, references resolved. Readers take what they support; `finish` rejects the
    rest, so nothing in the file is silently ignored."""

    def __init__(self, element, ids):
        self.element = element
        self.type = element.attrs.get("type")
        self.id = element.attrs.get("id")
        self.properties = {}   # name -> (property or object Element, the element naming it)
        self.objects = []      # unnamed nested objects
        self.ids = ids
        for child in element.children:
            target = child
            if child.tag == "ref":
                ref_id = _attribute(child, "id")
                if ref_id not in ids:
                    raise child.error(f"unknown id '{ref_id}'")
                target = ids[ref_id]
            elif child.tag not in PROPERTY_TAGS + OBJECT_TAGS:
                raise child.error(f"unexpected element <{child.tag}> in {element.where()}")
            name = child.attrs.get("name")
            if name is None:
                if child.tag in PROPERTY_TAGS:
                    raise child.error("a property needs a name attribute")
                self.objects.append(target)
            elif name in self.properties:
                raise child.error(f"parameter '{name}' given twice")
            else:
                self.properties[name] = (target, child)

    def error(self, message):
        return self.element.error(message)

    def has(self, name):
        return name in self.properties

    def take(self, name, tags):
        """The element of property `name` (removed), checked to be one of `tags`; None if absent."""
        if name not in self.properties:
            return None
        target, naming = self.properties.pop(name)
        if target.tag not in tags:
            raise naming.error(f"parameter '{name}' of {self.element.where()} must be "
                               f"<{'> or <'.join(tags)}>, got <{target.tag}>"
                               + (f" type '{target.attrs['type']}' (not supported here)" if "type" in target.attrs else ""))
        return target

    def number(self, name, default=None):
        element = self.take(name, ("float", "integer"))
        return default if element is None else _float(element)

    def integer(self, name, default=None):
        element = self.take(name, ("integer",))
        if element is None:
            return default
        text = _attribute(element, "value")
        try:
            return int(text)
        except ValueError:
            raise element.error(f"not an integer: {limits.show(text)}") from None

    def boolean(self, name, default=False):
        element = self.take(name, ("boolean",))
        if element is None:
            return default
        text = _attribute(element, "value").strip().lower()
        if text not in ("true", "false"):
            raise element.error(f"not a boolean (true or false): {element.attrs['value']!r}")
        return text == "true"

    def string(self, name, default=None):
        element = self.take(name, ("string",))
        return default if element is None else _attribute(element, "value")

    def color(self, name, default, warnings_, emitter=False):
        """An RGB triple from <rgb>, <spectrum> or <float> (constant values only)."""
        element = self.take(name, ("rgb", "spectrum", "float", "integer"))
        if element is None:
            return np.broadcast_to(np.asarray(default, float), (3,)).copy()
        return _color(element, warnings_, emitter)

    def point(self, name, default=None):
        element = self.take(name, ("point", "vector"))
        return default if element is None else _xyz(element, 0.0)

    def transform(self, name):
        element = self.take(name, ("transform",))
        return None if element is None else _transform(element)

    def object(self, name, tag):
        """The nested object passed as `name` (a named child or a named <ref>), as a Plugin."""
        element = self.take(name, (tag,))
        return None if element is None else Plugin(element, self.ids)

    def nested(self, tag):
        """The nested objects of kind `tag`, named or not (removed), as Plugins: Mitsuba hands a
        shape its BSDF, a medium its phase function etc. whatever their names."""
        found = [o for o in self.objects if o.tag == tag]
        self.objects = [o for o in self.objects if o.tag != tag]
        for name in [n for n, (target, _) in self.properties.items() if target.tag == tag]:
            found.append(self.properties.pop(name)[0])
        return [Plugin(o, self.ids) for o in found]

    def volume(self, name):
        """The <volume> passed as `name`, or None when `name` is absent or a constant value."""
        if name in self.properties and self.properties[name][0].tag == "volume":
            return self.object(name, "volume")
        return None

    def accept(self, *names):
        """Parameters with no effect on the image (output format, performance hints)."""
        for name in names:
            self.properties.pop(name, None)

    def finish(self):
        for name, (target, naming) in self.properties.items():
            raise naming.error(f"parameter '{name}' of {self.element.where()} is not supported "
                               "by clrender (docs/mitsuba-xml.md)")
        for target in self.objects:
            raise target.error(f"<{target.tag}> inside {self.element.where()} is not supported here")


def _numbers(element, text=None):
    text = _attribute(element, "value") if text is None else text
    try:
        return [float(v) for v in text.replace(",", " ").split()]
    except ValueError:
        raise element.error(f"not a list of numbers: {text!r}") from None


def _float(element, text=None):
    values = _numbers(element, text)
    if len(values) != 1:
        raise element.error(f"expected one number, got {element.attrs['value'] if text is None else text!r}")
    return values[0]


def _triple(element, text):
    """Three numbers from "x y z" or "x, y, z" (one number: all three)."""
    values = _numbers(element, text)
    if len(values) == 1:
        values = values * 3
    if len(values) != 3:
        raise element.error(f"expected 3 numbers, got {text!r}")
    return np.array(values)


def _xyz(element, default):
    """<point x= y= z=/>, <vector value="x y z"/> and the like."""
    if "value" in element.attrs:
        return _triple(element, element.attrs["value"])
    return np.array([_float(element, element.attrs.get(axis, str(default))) for axis in "xyz"])


def _color(element, warnings_, emitter):
    """Mitsuba's RGB variants: <rgb> and <float> as given; a uniform <spectrum> as given, but
    on an emitter it is an equal-energy illuminant (value x cie.equal_energy_rgb()); a sampled
    <spectrum> converted by cie.spectrum_to_rgb (clamped to [0, 1] unless on an emitter)."""
    if element.tag in ("float", "integer"):
        return np.full(3, _float(element))
    if element.tag == "rgb":
        values = _numbers(element)
        if len(values) == 1:
            values = values * 3
        if len(values) != 3:
            raise element.error(f"expected 3 numbers (or 1), got {element.attrs['value']!r}")
        return np.array(values)
    if "filename" in element.attrs or "value" not in element.attrs:
        raise element.error("only spectra given by value are supported (no .spd files)")
    text = element.attrs["value"]
    if ":" not in text:
        value = _float(element)
        if not emitter:
            return np.full(3, value)
        rgb = value * cie.equal_energy_rgb()
        warnings_.append(f"{element.where()}: a uniform spectrum on an emitter is an equal-energy "
                         f"illuminant in Mitsuba's RGB variants: RGB {_fmt(rgb)}")
        return rgb
    pairs = [item.split(":") for item in text.replace(",", " ").split()]
    try:
        wavelengths, values = np.array([[float(w), float(v)] for w, v in pairs]).T
    except ValueError:
        raise element.error(f"not a list of wavelength:value pairs: {text!r}") from None
    if len(wavelengths) < 2 or np.any(np.diff(wavelengths) <= 0):
        raise element.error("a sampled spectrum needs at least two increasing wavelengths")
    rgb = cie.spectrum_to_rgb(wavelengths, values, illuminant=emitter)
    clamped = np.maximum(rgb, 0.0) if emitter else np.clip(rgb, 0.0, 1.0)
    warnings_.append(f"{element.where()}: spectrum converted to RGB {_fmt(clamped)} (CIE 1931"
                     + (", D65" if not emitter else "") + ")"
                     + (f", clamped from {_fmt(rgb)}" if np.any(clamped != rgb) else ""))
    return clamped


def _fmt(values):
    return "(" + ", ".join(f"{v:.4g}" for v in values) + ")"


# ============================================================================================
# Transforms
# ============================================================================================
def _transform(element):
    """The 4x4 matrix of a <transform>: its operations in document order, each applied after
    (left-multiplied onto) the ones before, as in Mitsuba."""
    matrix = np.eye(4)
    for op in element.children:
        if op.tag == "translate":
            step = np.eye(4)
            step[:3, 3] = _xyz(op, 0.0)
        elif op.tag == "scale":
            step = np.diag([*_xyz(op, 1.0), 1.0])
        elif op.tag == "rotate":
            step = _rotation(op)
        elif op.tag == "matrix":
            values = _numbers(op)
            if len(values) == 9:
                step = np.eye(4)
                step[:3, :3] = np.reshape(values, (3, 3))
            elif len(values) == 16:
                step = np.reshape(values, (4, 4))
                if np.any(step[3] != [0, 0, 0, 1]):
                    raise op.error("projective matrices are not supported: the last row must be 0 0 0 1")
            else:
                raise op.error(f"a matrix has 9 or 16 numbers, got {len(values)}")
        elif op.tag == "lookat":
            step = _look_at(op)
        else:
            raise op.error(f"unknown transform operation <{op.tag}>")
        matrix = step @ matrix
    if not np.all(np.isfinite(matrix)):
        raise element.error("the transform is not finite")
    return matrix


def _rotation(op):
    """Rotation by `angle` degrees (counter-clockwise, right-handed) about the axis (x, y, z).
    Like Mitsuba, the axis is used as given: one that is not of unit length also scales and
    shears (Rodrigues' formula with that vector)."""
    if "angle" not in op.attrs:
        raise op.error("<rotate> needs an angle (degrees)")
    axis = _xyz(op, 0.0)
    if not np.any(axis):
        raise op.error("<rotate> needs a non-zero axis")
    x, y, z = axis
    angle = np.radians(_float(op, op.attrs["angle"]))
    c, s = np.cos(angle), np.sin(angle)
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    m = np.eye(4)
    m[:3, :3] = c * np.eye(3) + s * k + (1 - c) * np.outer([x, y, z], [x, y, z])
    return m


def _look_at(op):
    """Mitsuba's look_at: columns (left, up, direction, origin), left = up x direction."""
    origin = _triple(op, _attribute(op, "origin"))
    target = _triple(op, _attribute(op, "target"))
    up = _triple(op, op.attrs.get("up", "0 1 0"))
    direction = target - origin
    if np.linalg.norm(direction) == 0:
        raise op.error("origin and target coincide")
    direction /= np.linalg.norm(direction)
    left = np.cross(up, direction)
    if np.linalg.norm(left) < 1e-12:
        raise op.error("up is parallel to the viewing direction")
    left /= np.linalg.norm(left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, np.cross(direction, left), direction, origin
    return m


def _rotation_scale(matrix):
    """s when the linear part of `matrix` is s times a rotation (s > 0), else None."""
    linear = matrix[:3, :3]
    gram = linear.T @ linear
    scale2 = np.trace(gram) / 3
    if scale2 <= 0 or np.linalg.det(linear) <= 0 or not np.allclose(gram, scale2 * np.eye(3), rtol=0, atol=1e-6 * scale2):
        return None
    return float(np.sqrt(scale2))


def _is_rigid(matrix):
    """Whether the linear part of `matrix` is a rotation (up to float rounding)."""
    scale = _rotation_scale(matrix)
    return scale is not None and abs(scale - 1.0) < 1e-5


def _matrix_rows(matrix):
    return [[float(v) for v in row] for row in matrix]


# ============================================================================================
# The translation
# ============================================================================================
@dataclass
class Translation:
    """A Mitsuba scene as a scene dict, with what the reader noticed along the way."""
    scene: dict
    warnings: list = field(default_factory=list)   # approximations, one message each
    notes: list = field(default_factory=list)      # 'element -> scene field: summary', for info
    origins: dict = field(default_factory=dict)    # scene dict path ('shapes[2]') -> element place


class _Reader:
    """State of one translation: the scene dict being built and the shared objects."""

    def __init__(self, ids, files):
        self.ids = ids
        self.files = files
        self.out = Translation({"materials": [], "shapes": [], "lights": [], "media": []})
        self.material_names = {}   # (id() of the BSDF element or None, emission or None) -> name
        self.medium_names = {}     # id() of the medium element -> name
        self.ignore_media = False  # Mitsuba's `path` integrator renders without media
        self.has_area_emitters = False

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
    _check_version(root)
    files = _Files(path.parent.resolve())
    elements = _expand(root, {k: str(v) for k, v in (parameters or {}).items()}, files)
    ids = _collect_ids(elements)
    reader = _Reader(ids, files)
    reader.out.origins[""] = root.where()   # what no element accounts for: the file's <scene>
    by_tag = {}
    for element in elements:
        by_tag.setdefault(element.tag, []).append(element)
        if element.tag not in OBJECT_TAGS:
            raise element.error(f"unexpected element <{element.tag}> in <scene>")
    for tag in ("film", "sampler", "rfilter", "phase", "volume", "texture"):
        for element in by_tag.get(tag, []):
            if "id" not in element.attrs:
                raise element.error(f"a top-level <{tag}> must have an id (and be referenced)")
    integrators = by_tag.get("integrator", [])
    if len(integrators) > 1:
        raise integrators[1].error("only one <integrator> is allowed")
    read_integrator(Plugin(integrators[0], ids) if integrators else None, reader)
    sensors = by_tag.get("sensor", [])
    if len(sensors) != 1:
        raise (sensors[1].error("clrender renders one sensor: keep a single <sensor>") if sensors
               else root.error("the scene has no <sensor> (clrender needs a camera)"))
    read_sensor(Plugin(sensors[0], ids), reader)
    for element in by_tag.get("shape", []):
        read_shape(Plugin(element, ids), reader)
    for element in by_tag.get("emitter", []):
        read_emitter(Plugin(element, ids), reader)
    if reader.out.scene["render"].get("hide_environment") and reader.has_area_emitters:
        raise integrators[0].error(
            "hide_emitters with area emitters is not supported: Mitsuba makes emitting shapes "
            "transparent to camera rays, clrender only hides the environment")
    # Top-level <bsdf>/<medium> definitions are read where shapes reference them; unreferenced
    # ones have no effect, as in Mitsuba.
    return reader.out


def load_scene(path, parameters=None):
    """Load a Mitsuba 3 XML scene as a clrender Scene (validated like a JSON scene); emits a
    MitsubaXmlWarning per approximation."""
    translation = read_scene(path, parameters)
    for message in translation.warnings:
        warnings.warn(message, MitsubaXmlWarning, stacklevel=2)
    scene = scene_from_translation(translation)
    scene.path = Path(path)
    return scene


def scene_from_translation(translation):
    """Validate a Translation's dict with load_scene_dict; errors name the XML element."""
    from .scene import load_scene_dict

    try:
        scene = load_scene_dict(translation.scene)
    except SceneError as e:
        raise located(e, translation.origins) from None
    check_media_nesting(scene, translation)
    scene.origins = translation.origins
    return scene


def located(error, origins):
    """A SceneError naming a scene field, at the XML element the field came from."""
    origin = _origin(origins, error.where)
    if origin is None or isinstance(error, MitsubaXmlError):
        return error
    return MitsubaXmlError(origin, f"{error.message} (scene field {error.where})")


@contextmanager
def errors_at_source(scene):
    """SceneErrors found after loading (at upload: degenerate shapes, sizes for the device) name
    the XML element of the field, for a scene read from XML."""
    try:
        yield
    except SceneError as e:
        raise located(e, scene.origins or {}) from None


def _origin(origins, where):
    best = None
    for key in origins:
        if key in ("", where) or where.startswith(key + ".") or where.startswith(key + "["):
            if best is None or len(key) > len(best):
                best = key
    return origins.get(best)


# --------------------------------------------------------------------------------------------
# integrator
# --------------------------------------------------------------------------------------------
INTEGRATORS = ("path", "volpath", "volpathmis")
MAX_DEPTH = limits.MAX_DEPTH   # the format's limit; Mitsuba's -1 (unbounded) maps here: roulette ends paths first


def read_integrator(plugin, reader):
    """max_depth (-1: unbounded), rr_depth and hide_emitters of path/volpath/volpathmis.
    Roulette starts after vertex rr_depth in `path` but after vertex rr_depth + 1 in
    `volpath(mis)` (which tests depth > rr_depth before counting the next vertex)."""
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


# --------------------------------------------------------------------------------------------
# sensor, film, rfilter, sampler
# --------------------------------------------------------------------------------------------
DEFAULT_NEAR_CLIP, DEFAULT_FAR_CLIP = 0.01, 10000.0
SAMPLERS = ("independent", "stratified", "multijitter", "orthogonal", "ldsampler")


def read_sensor(plugin, reader):
    """perspective: the camera (position, look_at, up, vertical fov), film and sampler."""
    if plugin.type != "perspective":
        raise plugin.error(f"unsupported sensor '{plugin.type}' (supported: perspective)")
    films = plugin.nested("film")
    samplers = plugin.nested("sampler")
    media = plugin.nested("medium")
    if len(films) > 1 or len(samplers) > 1 or len(media) > 1:
        raise plugin.error("a sensor takes at most one film, one sampler and one medium")
    width, height = read_film(films[0] if films else None, reader)
    spp, seed, sampler = read_sampler(samplers[0] if samplers else None, reader)
    render = reader.out.scene["render"]
    render.update(spp=spp, seed=seed, sampler=sampler)
    matrix = plugin.transform("to_world")
    matrix = np.eye(4) if matrix is None else matrix
    if not _is_rigid(matrix):
        raise plugin.error("the sensor's to_world must be a rotation and translation (Mitsuba "
                           "rejects scale factors; mirroring or shearing the image is not supported)")
    fov_y = _vertical_fov(plugin, width / height)
    for name, default in (("near_clip", DEFAULT_NEAR_CLIP), ("far_clip", DEFAULT_FAR_CLIP)):
        value = plugin.number(name, default)
        if value != default:
            reader.warn(f"{plugin.element.where()}: {name} {value:g} ignored (clrender's camera "
                        "does not clip; differs only where geometry lies closer than near_clip or beyond far_clip)")
    for name in ("principal_point_offset_x", "principal_point_offset_y"):
        if plugin.number(name, 0.0) != 0.0:
            raise plugin.error(f"{name} is not supported (off-centre projections)")
    plugin.accept("shutter_open", "shutter_close")   # no effect on a static scene
    plugin.finish()
    position = matrix[:3, 3]
    forward = matrix[:3, :3] @ [0.0, 0.0, 1.0]
    camera = {"position": position.tolist(), "look_at": (position + forward / np.linalg.norm(forward)).tolist(),
              "up": (matrix[:3, :3] @ [0.0, 1.0, 0.0]).tolist(), "fov": fov_y,
              "resolution": [width, height]}
    reader.out.scene["camera"] = camera
    if media and not reader.ignore_media:
        name = read_medium(media[0], reader)
        camera["medium"] = name
        reader.out.scene["medium"] = name   # shapes without media leave the ray in it (see check_media_nesting)
    else:
        camera["medium"] = None
        if media:
            reader.warn(f"{media[0].element.where()}: ignored, as Mitsuba's `path` integrator ignores media")
    reader.note(plugin, "camera", f"{width} x {height}, vertical fov {fov_y:.6g} deg, {spp} spp, seed {seed}")


def _vertical_fov(plugin, aspect):
    """Mitsuba's fov along fov_axis (x, y, diagonal, smaller, larger; default x), or its
    focal_length (35 mm film, diagonal; default 50mm), as the vertical fov clrender uses."""
    if plugin.has("fov") and plugin.has("focal_length"):
        raise plugin.error("give either fov or focal_length")
    if plugin.has("focal_length"):
        text = plugin.string("focal_length")
        match = re.fullmatch(r"\s*([0-9.eE+-]+)\s*(mm)?\s*", text)
        if not match or not float(match.group(1)) > 0:
            raise plugin.error(f"focal_length must be like '50mm', got {text!r}")
        tan_half = np.hypot(36.0, 24.0) / (2 * float(match.group(1)))   # along `axis`
        axis = "diagonal"
    else:
        fov = plugin.number("fov", None)
        axis = plugin.string("fov_axis", "x").lower()
        if fov is None:
            tan_half, axis = np.hypot(36.0, 24.0) / (2 * 50.0), "diagonal"
        elif not 0 < fov < 180:
            raise plugin.error(f"fov must be in (0, 180) degrees, got {fov:g}")
        else:
            tan_half = np.tan(np.radians(fov) / 2)
    if axis == "smaller":
        axis = "x" if aspect <= 1 else "y"
    elif axis == "larger":
        axis = "y" if aspect <= 1 else "x"
    if axis == "x":
        tan_y = tan_half / aspect
    elif axis == "y":
        tan_y = tan_half
    elif axis == "diagonal":
        tan_y = tan_half / np.hypot(aspect, 1.0)
    else:
        raise plugin.error(f"unknown fov_axis '{axis}' (x, y, diagonal, smaller, larger)")
    return float(np.degrees(2 * np.arctan(tan_y)))


def read_film(plugin, reader):
    """hdrfilm: (width, height); a reconstruction filter other than box is a warning."""
    if plugin is None:
        reader.warn("no <film>: Mitsuba's default hdrfilm is 768 x 576 with a gaussian filter, "
                    "rendered with clrender's box filter")
        return 768, 576
    if plugin.type != "hdrfilm":
        raise plugin.error(f"unsupported film '{plugin.type}' (supported: hdrfilm)")
    width, height = plugin.integer("width", 768), plugin.integer("height", 576)
    if width < 1 or height < 1:
        raise plugin.error(f"width and height must be >= 1, got {width} x {height}")
    crop = (plugin.integer("crop_offset_x", 0), plugin.integer("crop_offset_y", 0),
            plugin.integer("crop_width", width), plugin.integer("crop_height", height))
    if crop != (0, 0, width, height):
        raise plugin.error("crop windows are not supported")
    plugin.accept("file_format", "pixel_format", "component_format", "sample_border", "compensate",
                  "banner", "high_quality_edges")   # output encoding only
    filters = plugin.nested("rfilter")
    if len(filters) > 1:
        raise plugin.error("a film takes one rfilter")
    rfilter = filters[0] if filters else None
    if rfilter is None or rfilter.type != "box":
        kind = "gaussian (Mitsuba's default)" if rfilter is None else f"'{rfilter.type}'"
        reader.warn(f"{(rfilter or plugin).element.where()}: reconstruction filter {kind} approximated by "
                    "clrender's box filter (each sample counts in its own pixel only): slightly sharper")
    plugin.finish()
    return width, height


def read_sampler(plugin, reader):
    """(spp, seed, our render.sampler). Samplers differ in how they stratify, not in what they
    estimate: Mitsuba's `independent` (its default) stays independent, its stratified ones
    become our Sobol sampler; the sample count is rounded as Mitsuba's samplers round it."""
    if plugin is None:
        return 4, 0, "independent"
    if plugin.type not in SAMPLERS:
        raise plugin.error(f"unsupported sampler '{plugin.type}' (supported: {', '.join(SAMPLERS)})")
    count = plugin.integer("sample_count", 4)
    seed = plugin.integer("seed", 0)
    if count < 1:
        raise plugin.error(f"sample_count must be >= 1, got {count}")
    plugin.accept("jitter", "strength", "dimension", "scramble_seed")
    plugin.finish()
    if plugin.type in ("stratified", "multijitter"):
        count = int(np.ceil(np.sqrt(count))) ** 2
    elif plugin.type == "ldsampler":
        count = 1 << int(np.ceil(np.log2(count)))
    elif plugin.type == "orthogonal":
        root = int(np.ceil(np.sqrt(count)))
        while any(root % d == 0 for d in range(2, int(np.sqrt(root)) + 1)) or root < 2:
            root += 1
        count = root * root
    return count, seed % 2**32, "independent" if plugin.type == "independent" else "sobol"


# --------------------------------------------------------------------------------------------
# bsdf
# --------------------------------------------------------------------------------------------
BSDFS = ("diffuse", "dielectric", "roughdielectric", "conductor", "roughconductor", "twosided", "null")

# Mitsuba's named indices of refraction.
IOR_PRESETS = {
    "vacuum": 1.0, "helium": 1.000036, "hydrogen": 1.000132, "air": 1.000277,
    "carbon dioxide": 1.00045, "water": 1.3330, "acetone": 1.36, "ethanol": 1.361,
    "carbon tetrachloride": 1.461, "glycerol": 1.4729, "benzene": 1.501, "silicone oil": 1.52045,
    "bromine": 1.661, "water ice": 1.31, "fused quartz": 1.458, "pyrex": 1.470,
    "acrylic glass": 1.49, "polypropylene": 1.49, "bk7": 1.5046, "sodium chloride": 1.544,
    "amber": 1.55, "pet": 1.575, "diamond": 2.419,
}

# Normal-incidence reflectance (linear RGB) of Mitsuba 3.9's conductor presets, from
# `conductor` in scalar_rgb: the weight of a sample at normal incidence (tests check it).
# AlSb is left out: Mitsuba's own RGB value is NaN.
CONDUCTOR_PRESETS = {
    "Ag": (0.9748, 0.9575, 0.9063), "Al": (0.928, 0.9178, 0.9189), "AlAs": (0.32, 0.2783, 0.143),
    "Au": (0.9667, 0.802, 0.3241), "Be": (0.5975, 0.5206, 0.5062), "Cr": (0.6876, 0.6491, 0.687),
    "CsI": (0.1325, 0.0675, 0.0619), "Cu": (0.952, 0.6198, 0.5106), "Cu2O": (0.3147, 0.2455, 0.2379),
    "CuO": (0.2907, 0.1982, 0.1834), "Cu_palik": (0.9494, 0.6217, 0.5092), "Hg": (0.814, 0.7702, 0.7631),
    "HgTe": (0.4699, 0.3665, 0.3507), "Ir": (0.7426, 0.6802, 0.6308), "K": (0.9539, 0.9363, 0.9201),
    "Li": (0.9248, 0.8844, 0.7933), "MgO": (0.1244, 0.0603, 0.0526), "Mo": (0.6182, 0.5618, 0.5409),
    "Na_palik": (0.9785, 0.9597, 0.9315), "Nb": (0.564, 0.4895, 0.4731), "Ni_palik": (0.7001, 0.5942, 0.4936),
    "Rh": (0.8243, 0.7544, 0.7216), "Se": (0.3793, 0.2507, 0.2413), "Se-e": (0.5019, 0.4029, 0.4225),
    "SiC": (0.2711, 0.1873, 0.1808), "SnTe": (0.407, 0.1084, 0.0152), "Ta": (0.4565, 0.3419, 0.3799),
    "Te": (0.635, 0.5781, 0.5617), "Te-e": (0.71, 0.6728, 0.6532), "ThF4": (0.0861, 0.0328, 0.0264),
    "TiC": (0.5482, 0.4397, 0.4116), "TiN": (0.6409, 0.4523, 0.1976), "TiO2": (0.3039, 0.2246, 0.238),
    "TiO2-e": (0.2631, 0.1855, 0.1951), "VC": (0.5297, 0.4179, 0.3798), "VN": (0.5251, 0.3926, 0.3106),
    "V_palik": (0.5727, 0.5107, 0.5365), "W": (0.5746, 0.4778, 0.4331), "a-C": (0.2794, 0.194, 0.1691),
    "d-C": (0.2123, 0.1579, 0.1449),
}
# The *_palik variants that equal their base preset.
CONDUCTOR_PRESETS.update({f"{name}_palik": CONDUCTOR_PRESETS[name] for name in (
    "AlAs", "Be", "CsI", "Cu2O", "CuO", "HgTe", "Ir", "K", "Li", "MgO", "Mo", "Nb", "Rh", "Se",
    "Se-e", "SiC", "SnTe", "Ta", "Te", "Te-e", "ThF4", "TiC", "TiN", "TiO2", "TiO2-e", "VC", "VN",
    "d-C")})
CONDUCTOR_PRESETS.update({"Hg_palik": CONDUCTOR_PRESETS["Hg"]})


def read_bsdf(plugin, reader, two_sided=False):
    """A material dict (without its name) for one BSDF element."""
    kind = plugin.type
    if kind == "twosided":
        inner = plugin.nested("bsdf")
        if len(inner) != 1:
            raise plugin.error("twosided with different front and back BSDFs is not supported "
                               "(give one nested BSDF)")
        plugin.finish()
        if inner[0].type not in ("diffuse", "conductor", "roughconductor"):
            raise inner[0].error(f"twosided around '{inner[0].type}' is not supported "
                                 "(only diffuse, conductor, roughconductor; Mitsuba rejects transmission)")
        return read_bsdf(inner[0], reader, two_sided=True)
    if kind == "diffuse":
        material = {"type": "diffuse", "albedo": plugin.color("reflectance", 0.5, reader.out.warnings).tolist(),
                    "two_sided": two_sided}
    elif kind in ("dielectric", "roughdielectric"):
        material = {"type": "dielectric", "ior": _ior(plugin, "int_ior", "bk7"),
                    "exterior_ior": _ior(plugin, "ext_ior", "air")}
        if np.any(plugin.color("specular_reflectance", 1.0, reader.out.warnings) != 1.0):
            raise plugin.error("specular_reflectance other than 1 is not supported on dielectrics")
        material["tint"] = plugin.color("specular_transmittance", 1.0, reader.out.warnings).tolist()
        if kind == "roughdielectric":
            material.update(_roughness(plugin))
    elif kind in ("conductor", "roughconductor"):
        material = {"type": "conductor", "two_sided": two_sided,
                    "tint": (plugin.color("specular_reflectance", 1.0, reader.out.warnings)
                             * _conductor_reflectance(plugin, reader)).tolist()}
        if kind == "roughconductor":
            material.update(_roughness(plugin))
    elif kind == "null":
        material = {"type": "interface"}
    else:
        raise plugin.error(f"unsupported BSDF '{kind}' (supported: {', '.join(BSDFS)})")
    plugin.finish()
    return material


def _ior(plugin, name, default):
    element = plugin.take(name, ("float", "integer", "string"))
    if element is None:
        return IOR_PRESETS[default]
    if element.tag == "string":
        value = element.attrs.get("value", "").lower()
        if value not in IOR_PRESETS:
            raise element.error(f"unknown index of refraction '{value}' (known: {', '.join(IOR_PRESETS)})")
        return IOR_PRESETS[value]
    return _float(element)


def _roughness(plugin):
    """GGX alpha -> the format's roughness (alpha = roughness^2); single scattering, as Mitsuba."""
    distribution = plugin.string("distribution", "beckmann")
    if distribution != "ggx":
        raise plugin.error(f"microfacet distribution '{distribution}' is not supported: clrender's "
                           "rough lobes are GGX (add <string name=\"distribution\" value=\"ggx\"/>; "
                           "Mitsuba's default is beckmann)")
    if plugin.has("alpha") and (plugin.has("alpha_u") or plugin.has("alpha_v")):
        raise plugin.error("give either alpha or alpha_u and alpha_v")
    alpha = plugin.number("alpha", 0.1)
    if plugin.has("alpha_u") or plugin.has("alpha_v"):
        alpha_u, alpha_v = plugin.number("alpha_u", 0.1), plugin.number("alpha_v", 0.1)
        if alpha_u != alpha_v:
            raise plugin.error("anisotropic roughness (alpha_u != alpha_v) is not supported")
        alpha = alpha_u
    if not 0 <= alpha <= 1:
        raise plugin.error(f"alpha must be in [0, 1], got {alpha:g}")
    plugin.accept("sample_visible")   # a sampling choice: the same image
    return {"roughness": float(np.sqrt(alpha)), "energy_compensation": False}


def _conductor_reflectance(plugin, reader):
    """Reflectance at normal incidence of the conductor's material or eta/k (1 for 'none')."""
    if plugin.has("material") and (plugin.has("eta") or plugin.has("k")):
        raise plugin.error("give either material or eta and k")
    if plugin.has("eta") or plugin.has("k"):
        eta = plugin.color("eta", 0.0, reader.out.warnings)
        k = plugin.color("k", 1.0, reader.out.warnings)
        f0 = ((eta - 1) ** 2 + k ** 2) / ((eta + 1) ** 2 + k ** 2)
        reader.warn(f"{plugin.element.where()}: eta/k approximated by the normal-incidence "
                    f"reflectance {_fmt(f0)} at every angle")
        return f0
    name = plugin.string("material", "none")
    if name == "none":
        return np.ones(3)
    if name not in CONDUCTOR_PRESETS:
        raise plugin.error(f"unknown conductor material '{name}' (known: none, {', '.join(sorted(CONDUCTOR_PRESETS))})")
    f0 = np.array(CONDUCTOR_PRESETS[name])
    reader.warn(f"{plugin.element.where()}: material '{name}' approximated by its normal-incidence "
                f"reflectance {_fmt(f0)} at every angle (no Fresnel darkening or colour shift)")
    return f0


def _material(plugin, reader, emission, emitter_where):
    """The name of the scene material for (BSDF, area emission), made once per distinct pair.
    A shape without a BSDF is diffuse 0.5, or black when it emits (as in Mitsuba)."""
    key = (id(plugin.element) if plugin else None, None if emission is None else tuple(emission))
    if key in reader.material_names:
        return reader.material_names[key]
    if plugin is None:
        material = {"type": "diffuse", "albedo": [0.0 if emission is not None else 0.5] * 3,
                    "two_sided": False}
        base = "emitter" if emission is not None else "default"
    else:
        material = read_bsdf(plugin, reader)
        base = plugin.id or f"bsdf_line{plugin.element.line}"
    if emission is not None:
        if material["type"] != "diffuse":
            raise MitsubaXmlError(emitter_where, f"an area emitter on a '{plugin.type}' BSDF is not "
                                                 "supported (only on diffuse BSDFs or none)")
        material["emission"] = list(emission)
        base += "_emitting" if plugin else ""
    name, suffix = base, 1
    taken = {m["name"] for m in reader.out.scene["materials"]}
    while name in taken:
        suffix += 1
        name = f"{base}_{suffix}"
    material["name"] = name
    index = len(reader.out.scene["materials"])
    reader.out.scene["materials"].append(material)
    if plugin is not None:
        reader.note(plugin, f"materials[{index}]", f"{material['type']} '{name}'")
    reader.material_names[key] = name
    return name


# --------------------------------------------------------------------------------------------
# shape
# --------------------------------------------------------------------------------------------
SHAPES = ("rectangle", "cube", "sphere", "disk", "obj", "ply")


def read_shape(plugin, reader):
    kind = plugin.type
    if kind not in SHAPES:
        raise plugin.error(f"unsupported shape '{kind}' (supported: {', '.join(SHAPES)})")
    index = len(reader.out.scene["shapes"])
    shape = {"name": plugin.id or f"{kind}_line{plugin.element.line}"}
    matrix = plugin.transform("to_world")
    if kind in ("obj", "ply"):
        shape["type"] = "mesh"
        shape["file"] = str(reader.files.resolve(plugin.string("filename") or _missing(plugin, "filename"),
                                                  plugin.element))
        shape["smooth"] = not plugin.boolean("face_normals", False)
        plugin.accept("flip_tex_coords")   # no textures
        summary = f"mesh {Path(shape['file']).name}"
    elif kind == "sphere":
        shape["type"] = "sphere"
        shape["center"] = plugin.point("center", np.zeros(3)).tolist()
        shape["radius"] = plugin.number("radius", 1.0)
        if matrix is not None and _rotation_scale(matrix) is None:
            raise plugin.error("a sphere's to_world must be a rotation, translation and uniform scale "
                               "(Mitsuba does not allow non-uniform scales on spheres)")
        summary = f"sphere radius {shape['radius']:g}"
    else:
        shape["type"] = {"cube": "box"}.get(kind, kind)
        summary = shape["type"]
    if matrix is not None:
        shape["transform"] = {"matrix": _matrix_rows(matrix)}
    if plugin.boolean("flip_normals", False):
        shape["flip_normals"] = True
    _read_shape_media(plugin, reader, shape)
    emitters = plugin.nested("emitter")
    if len(emitters) > 1:
        raise plugin.error("a shape takes at most one emitter")
    emission = None
    if emitters:
        emission = read_area_emitter(emitters[0], reader)
        reader.has_area_emitters = True
    bsdfs = plugin.nested("bsdf")
    if len(bsdfs) > 1:
        raise plugin.error("a shape takes at most one BSDF")
    bsdf = bsdfs[0] if bsdfs else None
    shape["material"] = _material(bsdf, reader, emission, emitters[0].element.where() if emitters else None)
    if bsdf is not None and bsdf.type == "null" and reader.ignore_media:
        raise bsdf.error("the null BSDF needs integrator volpath or volpathmis (Mitsuba's path "
                         "integrator lets rays through it but blocks shadow rays)")
    plugin.finish()
    reader.out.scene["shapes"].append(shape)
    reader.note(plugin, f"shapes[{index}]", f"{summary}, material '{shape['material']}'"
                + (f", emits {_fmt(emission)}" if emission is not None else ""))


def _missing(plugin, name):
    raise plugin.error(f"parameter '{name}' is required")


def _read_shape_media(plugin, reader, shape):
    """interior/exterior: given on one side only, the other is vacuum (as in Mitsuba); given on
    neither, the format's default (the camera's medium) applies."""
    interior, exterior = plugin.object("interior", "medium"), plugin.object("exterior", "medium")
    if (interior or exterior) and not reader.ignore_media:
        shape["interior"] = read_medium(interior, reader) if interior else None
        shape["exterior"] = read_medium(exterior, reader) if exterior else None
    elif interior or exterior:
        reader.warn(f"{plugin.element.where()}: interior/exterior media ignored, as Mitsuba's `path` "
                    "integrator ignores media")


def read_area_emitter(plugin, reader):
    if plugin.type != "area":
        raise plugin.error(f"only 'area' emitters can be attached to shapes, got '{plugin.type}'")
    radiance = plugin.color("radiance", 1.0, reader.out.warnings, emitter=True)
    plugin.finish()
    return [float(v) for v in radiance]


# --------------------------------------------------------------------------------------------
# emitter
# --------------------------------------------------------------------------------------------
EMITTERS = ("point", "directional", "constant", "envmap")
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


def _describe_light(light):
    if light["type"] == "point":
        return f"point at {_fmt(light['position'])}, intensity {_fmt(light['intensity'])}"
    if light["type"] == "directional":
        return f"directional towards {_fmt(light['direction'])}, irradiance {_fmt(light['irradiance'])}"
    if "image" in light:
        height, width, _ = light["image"].shape
        return f"environment image {width} x {height}"
    return f"constant environment {_fmt(light['radiance'])}"


def _read_envmap(plugin, reader):
    """envmap: Mitsuba looks its lat-long map up bilinearly (texel centres at u = (i + 0.5) / W
    from -z towards +x, rows at v = j / (H - 1) from +y), after to_world's inverse rotation;
    clrender's map is constant per texel, +y up, centre looking down -z. The map is resampled
    into clrender's convention at up to 8 times its resolution (ENVMAP_MAX_*), each texel the
    solid-angle weighted mean of 2 x 2 bilinear lookups (a warning says so)."""
    from .image import load_image

    filename = plugin.string("filename") or _missing(plugin, "filename")
    path = reader.files.resolve(filename, plugin.element)
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
        if not _is_rigid(matrix):
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


# --------------------------------------------------------------------------------------------
# medium, phase, volume
# --------------------------------------------------------------------------------------------
MEDIA = ("homogeneous", "heterogeneous")


def read_medium(plugin, reader):
    """The name of the scene medium for a medium element (made once per element)."""
    key = id(plugin.element)
    if key in reader.medium_names:
        return reader.medium_names[key]
    if plugin.type not in MEDIA:
        raise plugin.error(f"unsupported medium '{plugin.type}' (supported: {', '.join(MEDIA)})")
    warnings_ = reader.out.warnings
    index = len(reader.out.scene["media"])
    name = plugin.id or f"medium_line{plugin.element.line}"
    medium = {"name": name, "scale": plugin.number("scale", 1.0), "g": read_phase(plugin)}
    plugin.accept("sample_emitters", "has_spectral_extinction")   # sampling choices
    grid = plugin.volume("sigma_t")
    if plugin.has("sigma_a") or plugin.has("sigma_s"):
        if plugin.has("sigma_t") or plugin.has("albedo"):
            raise plugin.error("give either sigma_t and albedo, or sigma_a and sigma_s")
        medium["sigma_a"] = plugin.color("sigma_a", 0.0, warnings_).tolist()
        medium["sigma_s"] = plugin.color("sigma_s", 0.0, warnings_).tolist()
    else:
        albedo = plugin.volume("albedo")
        medium["albedo"] = (_constant_volume(albedo, reader) if albedo else plugin.color("albedo", 0.75, warnings_)).tolist()
        if grid is not None and grid.type == "constvolume":
            medium["sigma_t"] = _constant_volume(grid, reader).tolist()
            grid = None
        elif grid is None:
            medium["sigma_t"] = plugin.color("sigma_t", 1.0, warnings_).tolist()
    if grid is not None:
        if plugin.type != "heterogeneous":
            raise grid.error("a grid sigma_t needs a heterogeneous medium")
        medium.update(_read_grid_volume(grid, reader))
        medium["sigma_t"] = 1.0
    plugin.finish()
    reader.out.scene["media"].append(medium)
    reader.medium_names[key] = name
    reader.note(plugin, f"media[{index}]", f"{'grid' if 'density' in medium else 'homogeneous'} '{name}'")
    return name


def read_phase(plugin):
    """Henyey-Greenstein g of the medium's phase function (isotropic: 0; hg default 0.8)."""
    phases = plugin.nested("phase")
    if len(phases) > 1:
        raise plugin.error("a medium takes one phase function")
    if not phases or phases[0].type == "isotropic":
        g = 0.0
    elif phases[0].type == "hg":
        g = phases[0].number("g", 0.8)
    else:
        raise phases[0].error(f"unsupported phase function '{phases[0].type}' (supported: isotropic, hg)")
    if phases:
        phases[0].finish()
    return g


def _constant_volume(plugin, reader):
    if plugin.type != "constvolume":
        raise plugin.error(f"only constant albedo is supported (constvolume, rgb, float), got '{plugin.type}'")
    value = plugin.color("value", 0.75, reader.out.warnings)
    plugin.accept("to_world")   # a constant does not move
    plugin.finish()
    return value


def _read_grid_volume(plugin, reader):
    """gridvolume from a .vol file: density fields of a `grid` medium. Mitsuba puts the grid in
    the unit cube of its to_world (sample (i, j, k) at ((i + 0.5) / nx, ...), trilinear, clamped
    at the faces, zero outside), as clrender/grids.py does; with use_grid_bbox the file's
    bounding box is placed inside to_world instead."""
    from .grids import read_vol

    if plugin.type != "gridvolume":
        raise plugin.error(f"unsupported volume '{plugin.type}' for sigma_t (supported: gridvolume)")
    path = reader.files.resolve(plugin.string("filename") or _missing(plugin, "filename"), plugin.element)
    if path.suffix.lower() != ".vol":
        raise plugin.error(f"gridvolume reads Mitsuba .vol files, got {path.name}")
    matrix = plugin.transform("to_world")
    matrix = np.eye(4) if matrix is None else matrix
    if plugin.boolean("use_grid_bbox", False):
        try:
            _, bbox = read_vol(path)
        except (ValueError, OSError) as e:
            raise plugin.error(f"cannot load grid {path}: {e}") from None
        extent = bbox[1] - bbox[0]
        if not np.all(extent > 0):
            raise plugin.error(f"the grid's bounding box is empty: {bbox.tolist()}")
        matrix = matrix @ np.block([[np.diag(extent), bbox[0][:, None]], [np.zeros((1, 3)), np.ones((1, 1))]])
    if plugin.string("filter_type", "trilinear") != "trilinear":
        raise plugin.error("only trilinear filtering is supported")
    if plugin.string("wrap_mode", "clamp") != "clamp":
        raise plugin.error("only wrap_mode clamp is supported")
    if plugin.has("max_value"):
        raise plugin.error("max_value is not supported (clrender computes the grid's majorants)")
    plugin.accept("raw", "accel")   # single-channel data; hardware interpolation only
    plugin.finish()
    return {"type": "grid", "density": {"file": str(path)}, "transform": {"matrix": _matrix_rows(matrix)}}


# --------------------------------------------------------------------------------------------
# After validation
# --------------------------------------------------------------------------------------------
def check_media_nesting(scene, translation):
    """A shape that declares no media keeps, in Mitsuba, whatever medium the ray is in; clrender
    gives it the camera's medium on both sides. That differs when such a shape lies inside a
    shape whose interior is another medium: an error, rather than a different image."""
    declared = [i for i, shape in enumerate(translation.scene["shapes"])
                if "interior" in shape or "exterior" in shape]
    for i, shape in enumerate(scene.shapes):
        if i in declared:
            continue
        for j in declared:
            container = scene.shapes[j]
            if container.interior in (-1, scene.medium) or not _inside(_a_surface_point(shape.mesh), container.mesh):
                continue
            raise MitsubaXmlError(
                _origin(translation.origins, f"shapes[{i}]") or f"shapes[{i}]",
                f"this shape declares no interior/exterior but lies inside "
                f"{_origin(translation.origins, f'shapes[{j}]')}, whose interior is medium "
                f"'{scene.media[container.interior].name}': Mitsuba keeps that medium across it, "
                "clrender would not; give the shape interior and exterior explicitly")


def _a_surface_point(geometry):
    if isinstance(geometry, meshes.Sphere):
        return geometry.center + [geometry.radius, 0.0, 0.0]
    return geometry.vertices[0]


def _inside(point, mesh):
    """Whether `point` is inside a closed mesh or analytic sphere: for a mesh, the parity of a
    ray's crossings (Moller-Trumbore against every triangle; an oblique direction avoids edges of
    axis-aligned meshes)."""
    if isinstance(mesh, meshes.Sphere):
        return bool(np.linalg.norm(point - mesh.center) < mesh.radius)
    direction = np.array([0.5773, 0.5774, 0.5775])
    v0, v1, v2 = (mesh.vertices[mesh.faces[:, k]] for k in range(3))
    e1, e2 = v1 - v0, v2 - v0
    p = np.cross(direction, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-300
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = point - v0
    u = np.einsum("ij,ij->i", s, p) * inv
    q = np.cross(s, e1)
    v = (q @ direction) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    hits = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return int(np.count_nonzero(hits)) % 2 == 1
