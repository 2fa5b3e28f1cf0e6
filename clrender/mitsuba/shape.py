"""Shapes: triangle meshes and analytic spheres, each with its material (its BSDF and area emitter)
and media.

| plugin | parameter (Mitsuba's default) | clrender shape |
|---|---|---|
| `rectangle` | | `rectangle`: [-1, 1]^2 in z = 0, facing +z |
| `cube` | | `box`: [-1, 1]^3, outwards |
| `disk` | | `disk`: radius 1 in z = 0, facing +z |
| `sphere` | `center` (0), `radius` (1); to_world a rotation, translation and uniform scale | analytic `sphere` |
| `obj`, `ply` | `filename`, `face_normals` (false: smooth), `flip_tex_coords` (obj true, ply false) | `mesh` (`smooth`, `flip_tex_coords`) |
| `serialized` | `filename`, `shape_index` (0), `face_normals` (false: smooth); no `flip_tex_coords` (Mitsuba refuses it) | `mesh` (`smooth`, `shape_index`) |
| all | `to_world` | `transform` |
| | `flip_normals` (false) | `flip_normals` |
| | nested or referenced `bsdf` (bsdf.py; none: diffuse 0.5, black if emitting) | `material` |
| | nested `area` emitter (emitter.py) | the material's `emission` |
| | `interior`, `exterior` media (medium.py; one side given: the other is vacuum) | `interior`, `exterior` |
"""
from pathlib import Path

import numpy as np

from .bsdf import read_bsdf
from .emitter import read_area_emitter
from .medium import read_medium
from .texture import is_textured
from .transforms import matrix_rows, rotation_scale
from .values import fmt
from .xml import MitsubaXmlError

SHAPES = ("rectangle", "cube", "sphere", "disk", "obj", "ply", "serialized")
MESH_FILES = ("obj", "ply", "serialized")


def read_shape(plugin, reader):
    kind = plugin.type
    if kind not in SHAPES:
        raise plugin.error(f"unsupported shape '{kind}' (supported: {', '.join(SHAPES)})")
    index = len(reader.out.scene["shapes"])
    shape = {"name": plugin.id or f"{kind}_line{plugin.element.line}"}
    matrix = plugin.transform("to_world")
    if kind in MESH_FILES:
        shape.update(_mesh_file(plugin, reader))
        summary = f"mesh {Path(shape['file']).name}" + (f" shape {shape['shape_index']}" if "shape_index" in shape else "")
    elif kind == "sphere":
        shape["type"] = "sphere"
        shape["center"] = plugin.point("center", np.zeros(3)).tolist()
        shape["radius"] = plugin.number("radius", 1.0)
        if matrix is not None and rotation_scale(matrix) is None:
            raise plugin.error("a sphere's to_world must be a rotation, translation and uniform scale "
                               "(Mitsuba does not allow non-uniform scales on spheres)")
        summary = f"sphere radius {shape['radius']:g}"
    else:
        shape["type"] = {"cube": "box"}.get(kind, kind)
        summary = shape["type"]
    if matrix is not None:
        shape["transform"] = {"matrix": matrix_rows(matrix)}
    if plugin.boolean("flip_normals", False):
        shape["flip_normals"] = True
    _read_shape_media(plugin, reader, shape)
    emitters = plugin.nested("emitter")
    if len(emitters) > 1:
        raise plugin.error("a shape takes at most one emitter")
    emission = None
    if emitters:
        emission = read_area_emitter(emitters[0], reader)
    bsdfs = plugin.nested("bsdf")
    if len(bsdfs) > 1:
        raise plugin.error("a shape takes at most one BSDF")
    bsdf = bsdfs[0] if bsdfs else None
    shape["material"] = _material(bsdf, reader, emission, emitters[0].element.where() if emitters else None)
    if bsdf is not None and bsdf.type == "null" and reader.ignore_media:
        raise bsdf.error(f"the null BSDF needs integrator volpath or volpathmis (Mitsuba's {reader.integrator} "
                         "integrator lets rays through it but blocks shadow rays)")
    plugin.finish()
    reader.out.scene["shapes"].append(shape)
    reader.note(plugin, f"shapes[{index}]", f"{summary}, material '{shape['material']}'"
                + (f", emits {_describe_emission(emission)}" if emission is not None else ""))


def _describe_emission(emission):
    return f"texture '{emission['texture']}'" if is_textured(emission) else fmt(emission)


def _mesh_file(plugin, reader):
    """The `mesh` fields of an obj, ply or serialized shape. clrender picks a file's reader by
    its suffix, so the suffix must name the plugin's format."""
    path = plugin.file("filename", reader.files)
    if path.suffix.lower() != f".{plugin.type}":
        raise plugin.error(f"a '{plugin.type}' shape's file must end in .{plugin.type} (clrender reads mesh "
                           f"files by their suffix), got {path.name!r}")
    mesh = {"type": "mesh", "file": str(path), "smooth": not plugin.boolean("face_normals", False)}
    if plugin.type == "serialized":
        if plugin.has("flip_tex_coords"):
            raise plugin.error("a serialized shape has no flip_tex_coords: Mitsuba 3 refuses it (it keeps the "
                               "file's texture coordinates as stored)")
        mesh["shape_index"] = plugin.integer("shape_index", 0)
    elif plugin.has("flip_tex_coords"):
        mesh["flip_tex_coords"] = plugin.boolean("flip_tex_coords")
    return mesh


def _read_shape_media(plugin, reader, shape):
    """interior/exterior: given on one side only, the other is vacuum (as in Mitsuba); given on
    neither, the format's default (the camera's medium) applies."""
    interior, exterior = plugin.object("interior", "medium"), plugin.object("exterior", "medium")
    if (interior or exterior) and not reader.ignore_media:
        shape["interior"] = read_medium(interior, reader) if interior else None
        shape["exterior"] = read_medium(exterior, reader) if exterior else None
    elif interior or exterior:
        reader.warn(f"{plugin.element.where()}: interior/exterior media ignored, as Mitsuba's `{reader.integrator}` "
                    "integrator ignores media")


def _material(plugin, reader, emission, emitter_where):
    """The name of the scene material for (BSDF, area emission), made once per distinct pair.
    A shape without a BSDF is diffuse 0.5, or black when it emits (as in Mitsuba). The emission
    belongs to the front material; a twosided's back BSDF becomes a material of its own."""
    key = (id(plugin.element) if plugin else None, repr(emission))
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
        if material["type"] == "interface":
            raise MitsubaXmlError(emitter_where, "an area emitter on a 'null' BSDF is not supported (an "
                                                 "index-matched boundary is no surface to emit from)")
        material["emission"] = emission
        base += "_emitting" if plugin else ""
    back = material.pop("back", None)
    name = _add_material(material, base, reader, plugin)
    if back is not None:
        material["back"] = _add_material(back, f"{name}_back", reader, plugin)
    reader.material_names[key] = name
    return name


def _add_material(material, base, reader, plugin):
    """Add `material` to the scene under a free name made from `base`; returns the name."""
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
    return name
