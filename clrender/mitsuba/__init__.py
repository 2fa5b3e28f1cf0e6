"""Mitsuba 3 XML scenes: read a `scene.xml` into the scene dict of docs/scene-format.md.

The XML is parsed with each element's file and line, `<include>`, `<default>`/`$name`, `<path>`
and `<ref>` are resolved (xml.py), and each plugin is read by the module of its kind, as Mitsuba
keeps one folder per kind: integrator.py, sensor.py (film.py, rfilter.py, sampler.py), bsdf.py,
shape.py, emitter.py, medium.py (media, phase functions, volumes). Each opens with a table of the
plugins and parameters it reads. Plugin (plugin.py) reads properties by name and type
(values.py, transforms.py) and rejects what no reader took. The driver (translation.py) reads
the scene's top-level plugins through its table SCENE_PLUGINS; the result goes through
`load_scene_dict` like any JSON scene, so every check of the format applies, its errors reported
at the XML element they came from. Anything outside the supported subset is a MitsubaXmlError
naming the element, its type and its line; the few unavoidable approximations
(docs/mitsuba-xml.md) are MitsubaXmlWarnings.

    scene = clrender.load_scene("scene.xml", parameters={"spp": "64"})
"""
from .bsdf import IOR_PRESETS
from .translation import Translation, read_scene, read_scene_file
from .xml import PARAMETER_NAME, MitsubaXmlError, MitsubaXmlWarning

__all__ = ["IOR_PRESETS", "PARAMETER_NAME", "MitsubaXmlError", "MitsubaXmlWarning",
           "Translation", "read_scene", "read_scene_file"]
