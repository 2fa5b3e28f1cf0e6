"""The XML of a Mitsuba scene: elements with their file and line, and the pre-processing Mitsuba
does before it makes any plugin.

| element | |
|---|---|
| `<scene version="3.x">` | the root of the scene and of every included file; 2.x too (READ_VERSIONS) |
| `<default name value>`, `$name` | substituted in every attribute, in document order; parameters given to the reader (`-D`) override defaults |
| `<include filename>` | spliced in place, nested up to MAX_INCLUDE_DEPTH, at most limits.MAX_XML_INCLUDES in all |
| `<path value>` | a folder where file names are also looked up (`Files`) |
| `id` attributes | collected for `<ref>` (`collect_ids`) |

Bounded work for bounded input: every file is a regular file, each and the included ones
together at most limits.MAX_SCENE_FILE_BYTES, checked before reading; substitution adds at most
limits.MAX_SUBSTITUTED_CHARS characters to a scene (a value of 1 MB used a million times would
be a terabyte); the XML declaration's encoding must be one expat can read.
"""
import re
import xml.parsers.expat
from dataclasses import dataclass, field
from pathlib import Path

from .. import limits
from ..errors import SceneError
from ..files import describe, not_a_file, resolved
from ..loader import read_scene_bytes


class MitsubaXmlError(SceneError):
    """A Mitsuba XML scene that clrender cannot read; `where` is 'file.xml:LINE <tag type=...>'."""


class MitsubaXmlWarning(UserWarning):
    """A Mitsuba feature that clrender renders approximately (docs/mitsuba-xml.md)."""


PARAMETER_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")   # what $name may name (and -D set)
_PARAMETER = re.compile(r"\$(" + PARAMETER_NAME.pattern + ")")
# Scene versions (major) read: Mitsuba 3 reads 2.x files as 3.x (its parser upgrades only older
# files, whose camelCase parameter names it renames), and Mitsuba 2 and 3 name the parameters read
# here alike.
READ_VERSIONS = ("2", "3")
MAX_INCLUDE_DEPTH = 16
MAX_NESTING = 100   # elements inside elements: real scenes need a handful
# The elements that make plugins (objects); the others are properties or pre-processing.
OBJECT_TAGS = ("integrator", "sensor", "film", "sampler", "rfilter", "bsdf", "shape", "emitter",
               "medium", "phase", "volume", "texture")


@dataclass
class Element:
    tag: str
    attrs: dict
    file: Path
    line: int
    children: list = field(default_factory=list)

    def where(self):
        kind = f" type={limits.show(self.attrs['type'])}" if "type" in self.attrs else ""
        name = f" name={limits.show(self.attrs['name'])}" if "name" in self.attrs else ""
        return f"{self.file.name}:{self.line} <{self.tag}{kind}{name}>"

    def error(self, message):
        return MitsubaXmlError(self.where(), message)


def attribute(element, name):
    if name not in element.attrs:
        raise element.error(f"missing attribute '{name}'")
    return element.attrs[name]


def parse_xml(path):
    """The root Element of an XML file."""
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
    except (LookupError, ValueError) as e:   # encoding="x": unknown, or a multi-byte one expat cannot read
        raise MitsubaXmlError(f"{path.name}:{parser.CurrentLineNumber}",
                              f"cannot read the encoding of the XML declaration: {e}; use UTF-8") from None
    return roots[0]


def check_version(root):
    if root.tag != "scene":
        raise root.error("the root element must be <scene>")
    version = root.attrs.get("version")
    if version is None:
        raise root.error("<scene> needs a version attribute (e.g. version=\"3.0.0\")")
    if version.split(".")[0] not in READ_VERSIONS:
        raise root.error(f"scene version {version}: only versions 2.x and 3.x are supported, which "
                         "Mitsuba 3 reads alike (it renames the parameters of older files as it loads them)")


class Files:
    """Relative file names resolve against the folder of the XML file that names them, then the
    main scene's folder, then folders added by <path> (Mitsuba's file resolver). Also what the
    scene has used of the reader's bounds: includes, bytes read, characters substituted."""

    def __init__(self, scene_dir):
        self.search = [scene_dir]
        self.includes = 0
        self.bytes_read = 0
        self.substituted = 0

    def resolve(self, name, element):
        name = Path(name)
        if name.is_absolute():
            candidates = [name]
        else:
            candidates = [element.file.parent / name] + [folder / name for folder in self.search]
        problems = [not_a_file(candidate) for candidate in candidates]   # None: a regular file
        for candidate, problem in zip(candidates, problems):
            if problem is None:
                return resolved(candidate)
        for candidate, problem in zip(candidates, problems):   # there, but a folder or a named pipe: say so
            if problem != "not found":
                raise element.error(describe(candidate))
        raise element.error(f"file not found: {name} (looked in: "
                            f"{', '.join(str(c.parent) for c in candidates)})")


def _substitute(element, parameters, files):
    """A copy of `element` and its subtree with $name replaced in every attribute value; the
    characters added count against limits.MAX_SUBSTITUTED_CHARS (files.substituted), checked
    before each value is built."""
    def value(key, text):
        names = _PARAMETER.findall(text)
        for name in names:
            if name not in parameters:
                raise element.error(f"undefined parameter ${name} (give it a <default> "
                                    "or pass it, e.g. -D name=value)")
        files.substituted += sum(len(parameters[name]) - len(name) - 1 for name in names)
        if files.substituted > limits.MAX_SUBSTITUTED_CHARS:
            raise element.error(f"attribute {key}: $name substitution makes the scene more than "
                                f"{limits.MAX_SUBSTITUTED_CHARS} characters longer")
        return _PARAMETER.sub(lambda match: parameters[match.group(1)], text) if names else text

    attrs = {key: value(key, text) for key, text in element.attrs.items()}
    copy = Element(element.tag, attrs, element.file, element.line)
    copy.children = [_substitute(child, parameters, files) for child in element.children]
    return copy


def expand(root, parameters, files, depth=0):
    """The scene's top-level elements after includes, defaults and substitution, in order."""
    elements = []
    for child in root.children:
        if child.tag == "default":
            name, text = child.attrs.get("name"), child.attrs.get("value")
            if name is None or text is None:
                raise child.error("<default> needs name and value attributes")
            parameters.setdefault(name, text)
        elif child.tag == "include":
            child = _substitute(child, parameters, files)
            if depth >= MAX_INCLUDE_DEPTH:
                raise child.error(f"includes nested deeper than {MAX_INCLUDE_DEPTH} (a cycle?)")
            files.includes += 1
            if files.includes > limits.MAX_XML_INCLUDES:
                raise child.error(f"more than {limits.MAX_XML_INCLUDES} includes in one scene "
                                  "(a file included many times over?)")
            included = _parse_included(files.resolve(attribute(child, "filename"), child), files, child)
            check_version(included)
            elements += expand(included, parameters, files, depth + 1)
        elif child.tag == "path":
            child = _substitute(child, parameters, files)
            folder = (child.file.parent / attribute(child, "value")).resolve()
            if not folder.is_dir():
                raise child.error(f"folder not found: {folder}")
            files.search.append(folder)
        else:
            elements.append(_substitute(child, parameters, files))
    return elements


def _parse_included(path, files, include):
    """The root of an included file, its size counted with the other included files' against
    the limit before it is read."""
    files.bytes_read += path.stat().st_size
    if files.bytes_read > limits.MAX_SCENE_FILE_BYTES:
        raise include.error(f"the included files are more than {limits.MAX_SCENE_FILE_BYTES} bytes together "
                            f"({path.name} and those included before it)")
    return parse_xml(path)


def collect_ids(elements):
    """id -> the object element carrying it, over the whole tree; duplicates are errors."""
    ids = {}

    def visit(element):
        if "id" in element.attrs and element.tag in OBJECT_TAGS:
            if element.attrs["id"] in ids:
                first = ids[element.attrs["id"]]
                raise element.error(f"duplicate id {limits.show(element.attrs['id'])} (first at line {first.line})")
            ids[element.attrs["id"]] = element
        for child in element.children:
            visit(child)

    for element in elements:
        visit(element)
    return ids
