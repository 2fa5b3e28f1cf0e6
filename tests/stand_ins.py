"""Stand-ins for the absent assets of the XML-only real scenes (../shared/real-scenes/xml-only,
SOURCES.md there): a copy of a scene file beside small files at every path it names, so that a
reader meets the file it expects (an OBJ, a PLY, an image, a .vol grid) and stops only where the
scene itself asks for what it cannot do."""
import shutil

import numpy as np
import OpenImageIO as oiio

from clrender import grids
from clrender.image import save_image
from clrender.mitsuba.xml import Files, expand, parse_xml
from mesh_writers import write_ply_file

# A unit square in z = 0 facing +z, with texture coordinates and normals.
SQUARE = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
SQUARE_FACES = [[0, 1, 2], [0, 2, 3]]


def referenced_files(path, parameters):
    """The values of the `filename` strings of the scene `path` read with `parameters` (-D)."""
    elements = expand(parse_xml(path), parameters, Files(path.parent.resolve()))
    stack, names = list(elements), []
    while stack:
        element = stack.pop()
        stack.extend(element.children)
        if element.tag == "string" and element.attrs.get("name") == "filename":
            names.append(element.attrs["value"])
    return sorted(set(names))


def write_stand_in(path):
    """A small valid file of the kind `path`'s suffix names."""
    path.parent.mkdir(parents=True, exist_ok=True)
    suffix = path.suffix.lower()
    if suffix == ".obj":
        lines = [f"v {x} {y} {z}" for x, y, z in SQUARE] + [f"vt {(x + 1) / 2} {(y + 1) / 2}" for x, y, _ in SQUARE]
        lines += ["vn 0 0 1"] + [f"f {a + 1}/{a + 1}/1 {b + 1}/{b + 1}/1 {c + 1}/{c + 1}/1" for a, b, c in SQUARE_FACES]
        path.write_text("\n".join(lines) + "\n")
    elif suffix == ".ply":
        write_ply_file(path, "binary_little_endian", {axis: ("float", SQUARE[:, i]) for i, axis in enumerate("xyz")},
                       SQUARE_FACES)
    elif suffix in (".png", ".jpg", ".jpeg", ".exr"):
        save_image(np.full((4, 8, 3), 0.5, np.float32), path)
    elif suffix == ".hdr":
        output = oiio.ImageOutput.create(str(path))
        output.open(str(path), oiio.ImageSpec(8, 4, 3, "float"))
        output.write_image(np.full((4, 8, 3), 0.5, np.float32))
        output.close()
    elif suffix == ".vol":
        grids.write_vol(path, np.full((4, 4, 4), 0.5, np.float32))
    else:
        raise ValueError(f"no stand-in for {path.name}")


def copy_with_stand_ins(scene, folder, parameters):
    """The scene file `scene` copied into `folder`, with stand-ins for the files it names."""
    copy = folder / scene.name
    shutil.copy(scene, copy)
    for name in referenced_files(copy, parameters):
        write_stand_in(folder / name)
    return copy
