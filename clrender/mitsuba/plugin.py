"""`Plugin`: an object element (`<bsdf type="diffuse">` ...) and the typed reading of its
properties. A plugin-kind module takes what it supports, by name and type; `finish` rejects the
rest, so nothing in the file is silently ignored.

| property | read by |
|---|---|
| `<float>`, `<integer>` | `number` (either), `integer` |
| `<boolean>`, `<string>` | `boolean`, `string`; `file` resolves a file name |
| `<rgb>`, `<spectrum>`, `<float>` | `color` (values.parse_color) |
| `<point>`, `<vector>` | `point` |
| `<transform>` | `transform` (transforms.parse_transform) |
| nested objects, `<ref>` | `object` (by name), `nested` (by kind, named or not), `volume` |
"""
import numpy as np

from .. import limits
from .transforms import parse_transform
from .values import parse_color, parse_float, parse_xyz
from .xml import OBJECT_TAGS, attribute

PROPERTY_TAGS = ("float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector",
                 "transform")


class Plugin:
    """An object element: its properties by name and its unnamed nested objects, references
    resolved."""

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
                ref_id = attribute(child, "id")
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
        return default if element is None else parse_float(element)

    def integer(self, name, default=None):
        element = self.take(name, ("integer",))
        if element is None:
            return default
        text = attribute(element, "value")
        try:
            return int(text)
        except ValueError:
            raise element.error(f"not an integer: {limits.show(text)}") from None

    def boolean(self, name, default=False):
        element = self.take(name, ("boolean",))
        if element is None:
            return default
        text = attribute(element, "value").strip().lower()
        if text not in ("true", "false"):
            raise element.error(f"not a boolean (true or false): {element.attrs['value']!r}")
        return text == "true"

    def string(self, name, default=None):
        element = self.take(name, ("string",))
        return default if element is None else attribute(element, "value")

    def file(self, name, files):
        """The file named by the required string property `name`, found by `files` (xml.Files)."""
        filename = self.string(name)
        if not filename:
            raise self.error(f"parameter '{name}' is required")
        return files.resolve(filename, self.element)

    def color(self, name, default, warnings_, emitter=False):
        """An RGB triple from <rgb>, <spectrum> or <float> (constant values only)."""
        element = self.take(name, ("rgb", "spectrum", "float", "integer"))
        if element is None:
            return np.broadcast_to(np.asarray(default, float), (3,)).copy()
        return parse_color(element, warnings_, emitter)

    def point(self, name, default=None):
        element = self.take(name, ("point", "vector"))
        return default if element is None else parse_xyz(element, 0.0)

    def transform(self, name):
        element = self.take(name, ("transform",))
        return None if element is None else parse_transform(element)

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
