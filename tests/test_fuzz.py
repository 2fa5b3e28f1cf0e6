"""Property-based fuzzing (hypothesis) of what a user hands to clrender: scene dicts (valid ones
perturbed field by field), scene files (duplicated keys, damaged text, other encodings), mesh
files, grid files and damaged Mitsuba XML scenes.

The property: loading either raises a SceneError that names its place (a JSON path; for a file
that cannot be read as JSON at all, the file; for XML, the file's line and element), or gives a
scene whose tiny render (4 x 4 pixels, 1 spp, depth 3) is finite everywhere or stops at upload
with such a SceneError. Nothing else may escape.

Round 2 (issue 26) adds what a run does around the scene: XML include graphs, $name chains and
encodings (bounded time, printable errors at a file's line); sets of batch and AOV outputs, and
signals at random points of local and distributed renders and batches (every file that existed
before is untouched or an output the user named); scheduler stand-ins on 127.0.0.1 (exit 4
naming the address within the connect time-out). These run the CLI, some in subprocesses: few
examples, each with a time bound.

Loading is cheap and every example is loaded; rendering is not, so at most FUZZ_RENDERS loaded
scenes per test are rendered, on the session's context (kernels built once per feature set).
The examples are derandomized (the same ones every run, so CI is reproducible); set
CLRENDER_FUZZ_EXAMPLES=N to run N random examples per test instead (N / 20 renders).
"""
import copy
import json
import math
import os
import re
import signal
import struct
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import clrender
import mitsuba_scenes
from mesh_writers import write_ply_file, write_serialized
from clrender.arrays import SkippedShapeWarning
from clrender.errors import SceneError

_REQUESTED = int(os.environ.get("CLRENDER_FUZZ_EXAMPLES", "0"))
FUZZ_RENDERS = max(_REQUESTED // 20, 30) if _REQUESTED else 30


def fuzz_settings(examples):
    return settings(max_examples=_REQUESTED or examples, derandomize=not _REQUESTED, database=None,
                    deadline=None, suppress_health_check=list(HealthCheck), print_blob=True)


# ---------------------------------------------------------------------------------------------
# The property
# ---------------------------------------------------------------------------------------------
class Renders:
    """Tiny renders of every `every`-th loaded scene on one context, at most `limit` per test."""

    def __init__(self, context, every=1, limit=FUZZ_RENDERS):
        self.context, self.every, self.limit = context, every, limit
        self.loaded = self.done = 0

    def check(self, scene, names_its_place=lambda e: e.where):
        self.loaded += 1
        if self.done >= self.limit or self.loaded % self.every:
            return
        self.done += 1
        event("rendered")
        scene.camera.resolution = (4, 4)
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                depth = {} if scene.render.integrator == "direct" else {"max_depth": 3}   # direct has none
                result = clrender.Renderer(scene, context=self.context).render(spp=1, **depth)
        except SceneError as e:   # found at upload: degenerate shapes, sizes, scaled values
            assert names_its_place(e), e
            event("SceneError at upload")
            return
        for warning in caught:   # a shape none of whose triangles has an area
            assert warning.category is SkippedShapeWarning, warning.message
            event("shape without area skipped")
        assert np.all(np.isfinite(result.image)), result.image
        if result.discarded_samples:   # reported to the user; counted here to watch the rate
            event("rendered with non-finite samples discarded")


def load_or_explain(load, renders, names_its_place):
    """Run `load`: a SceneError must satisfy `names_its_place`, a scene must render finite."""
    try:
        scene = load()
    except SceneError as e:
        assert names_its_place(e), e
        event("SceneError")
        return
    event("loaded")
    renders.check(scene, names_its_place)


# ---------------------------------------------------------------------------------------------
# Valid scenes
# ---------------------------------------------------------------------------------------------
def vec(low=-3.0, high=3.0):
    return st.lists(st.floats(low, high), min_size=3, max_size=3)


def colour():
    return st.one_of(st.floats(0, 1), st.lists(st.floats(0, 1), min_size=3, max_size=3))


@st.composite
def valid_scenes(draw):
    """A small valid scene using every kind of material, shape, light and medium."""
    materials = [{"name": "white", "type": "diffuse", "albedo": draw(vec(0, 1)), "two_sided": draw(st.booleans())},
                 {"name": "lamp", "type": "emissive", "radiance": draw(st.floats(0.1, 20))}]
    extra = draw(st.sets(st.sampled_from(["glass", "metal", "toon", "boundary", "glow"])))
    if "glass" in extra:
        materials.append({"name": "glass", "type": "dielectric", "ior": draw(st.floats(1.01, 3)),
                          "roughness": draw(st.floats(0, 1)), "tint": draw(colour())})
    if "metal" in extra:
        materials.append({"name": "metal", "type": "conductor", "roughness": draw(st.floats(0, 1)),
                          "energy_compensation": draw(st.booleans()), "two_sided": draw(st.booleans())})
    if "toon" in extra:
        materials.append({"name": "toon", "type": "toon", "color": draw(colour()), "ambient": draw(colour()),
                          "bands": draw(st.integers(1, 4)), "highlight": {"size": 0.05},
                          "rim": {"threshold": 0.3, "color": [1, 0.5, 0.5]}})
    if "boundary" in extra:
        materials.append({"name": "boundary", "type": "interface"})
    if "glow" in extra:
        materials.append({"name": "glow", "type": "diffuse", "emission": draw(vec(0, 5))})
    names = [m["name"] for m in materials]
    media = []
    if draw(st.booleans()):
        media.append({"name": "fog", "sigma_a": draw(st.floats(0, 0.3)), "sigma_s": draw(vec(0, 0.3)),
                      "g": draw(st.floats(-0.9, 0.9))})
    if draw(st.booleans()):
        media.append({"name": "cloud", "type": "grid", "sigma_t": draw(st.floats(0.1, 5)),
                      "albedo": draw(st.floats(0, 1)),
                      "density": {"procedural": draw(st.sampled_from(["noise_cloud", "constant", "gradient",
                                                                       "sphere_falloff", "smoke_plume"])),
                                  "resolution": draw(st.lists(st.integers(1, 6), min_size=3, max_size=3))},
                      "transform": {"scale": 2, "translate": [-1, -1, -1]}})
    medium_names = [m["name"] for m in media]
    shapes = [{"type": "rectangle", "material": "lamp",
               "transform": {"translate": [0, 2.5, 0], "rotate": [90, 0, 0], "scale": 0.5}}]
    for _ in range(draw(st.integers(1, 3))):
        shape = {"type": draw(st.sampled_from(["box", "sphere", "rectangle", "disk"])),
                 "material": draw(st.sampled_from(names)),
                 "transform": {"translate": draw(vec(-1, 1)), "rotate": draw(vec(-90, 90)),
                               "scale": draw(st.floats(0.2, 1.5))}}
        if shape["type"] == "sphere":
            shape["subdivisions"] = draw(st.integers(0, 2))
            shape["smooth"] = draw(st.booleans())
        if shape["type"] == "disk":
            shape["segments"] = draw(st.integers(3, 64))
        if medium_names and draw(st.booleans()):
            shape["interior"] = draw(st.sampled_from(medium_names))
        shapes.append(shape)
    lights = []
    for kind in draw(st.sets(st.sampled_from(["environment", "point", "directional"]))):
        if kind == "environment":
            lights.append({"type": "environment", "radiance": draw(colour())})
        elif kind == "point":
            lights.append({"type": "point", "position": draw(vec(-2, 2)), "intensity": draw(st.floats(0, 10))})
        else:
            lights.append({"type": "directional", "direction": [0.3, -1, 0.2], "irradiance": draw(vec(0, 3))})
    scene = {
        "camera": {"position": [0, 1, 6], "look_at": draw(vec(-0.5, 0.5)), "up": [0, 1, 0],
                   "fov": draw(st.floats(10, 90)), "resolution": [4, 4]},
        "render": {"spp": 1, "max_depth": draw(st.integers(1, 6)), "rr_depth": draw(st.integers(1, 4)),
                   "seed": draw(st.integers(0, 2**32 - 1)),
                   "volume_method": draw(st.sampled_from(["null", "raymarch"])), "step": 0.1,
                   "hide_environment": draw(st.booleans())},
        "materials": materials, "shapes": shapes, "lights": lights, "media": media,
    }
    if "cloud" in medium_names:
        scene["medium"] = "cloud" if "fog" not in medium_names or draw(st.booleans()) else "fog"
    if draw(st.booleans()):
        scene["outlines"] = {"width": draw(st.floats(0.5, 3)), "depth_threshold": 0.1, "crease_angle": 40}
    return scene


# ---------------------------------------------------------------------------------------------
# Perturbations
# ---------------------------------------------------------------------------------------------
HOSTILE_NUMBERS = [0, -1, 1, 2, 0.5, -0.0, 1e-45, 5e-324, 1e-300, 1e-38, 1e-20, 1e20, 3.4e38, 1e39,
                   1e308, -1e308, 2**31 - 1, 2**31, 2**32 - 1, 2**32, 2**63, 10**400, -(10**400),
                   math.nan, math.inf, -math.inf, 1025, 16385]
HOSTILE_VALUES = HOSTILE_NUMBERS + [True, False, None, "", "x", "white", "fog", [], [1], [1, 2],
                                    [1, 2, 3], [1, 2, 3, 4], [[1, 2, 3]], ["a", "b", "c"], {}, {"x": 1},
                                    [math.nan, 0, 0], [1e39, 0, 0], [0, 0, 0], [-1, -1, -1],
                                    [2**40, 1, 1], [[[[[[]]]]]]]


def paths(value, prefix=()):
    """Every place in a JSON value: (path as a tuple of keys and indices)."""
    found = [prefix]
    if isinstance(value, dict):
        for key, item in value.items():
            found += paths(item, prefix + (key,))
    elif isinstance(value, list):
        for index, item in enumerate(value):
            found += paths(item, prefix + (index,))
    return found


def perturb(data, draw):
    """Apply one perturbation at a random place: replace the value (a wrong type, a hostile
    number, a value from elsewhere in the scene), scale a number, delete the key or list item,
    duplicate a list item, or add an unknown key."""
    path = draw(st.sampled_from(paths(data)[1:]))
    parent = data
    for key in path[:-1]:
        parent = parent[key]
    key = path[-1]
    action = draw(st.sampled_from(["replace", "replace", "replace", "scale", "delete", "duplicate", "unknown"]))
    if action == "replace":
        parent[key] = copy.deepcopy(draw(st.one_of(st.sampled_from(HOSTILE_VALUES),
                                                   st.floats(allow_nan=True, allow_infinity=True),
                                                   st.integers(-(2**70), 2**70))))
    elif action == "scale" and isinstance(parent[key], (int, float)) and not isinstance(parent[key], bool):
        parent[key] = parent[key] * draw(st.sampled_from([-1, 0, 1e-30, 1e-10, 1e10, 1e30, 1e300]))
    elif action == "delete":
        del parent[key]
    elif action == "duplicate" and isinstance(parent, list):
        parent.insert(key, copy.deepcopy(parent[key]))
    elif action == "unknown" and isinstance(parent[key], dict):
        parent[key][draw(st.sampled_from(["colour", "x", "Type", ""]))] = 1


@pytest.fixture
def renders(context):
    """One per test (hypothesis runs all of a test's examples with the same fixture)."""
    return Renders(context)


@fuzz_settings(1500)
@given(scene=valid_scenes(), data=st.data())
def test_perturbed_scene_dicts_load_or_explain(scene, data, renders):
    renders.every = 20   # most perturbed scenes load: spread the renders over the run
    for _ in range(data.draw(st.integers(0, 3), label="perturbations")):
        perturb(scene, data.draw)
    top_level = set(scene) | {"camera", "materials", "shapes", "lights", "media", "render", "outlines", "medium"}
    load_or_explain(lambda: clrender.load_scene_dict(scene), renders,
                    lambda e: e.where.split(".")[0].split("[")[0] in top_level)


# ---------------------------------------------------------------------------------------------
# Scene files: text-level damage
# ---------------------------------------------------------------------------------------------
@st.composite
def damaged_texts(draw):
    text = json.dumps(draw(valid_scenes()), indent=1)
    lines = text.splitlines(keepends=True)
    kind = draw(st.sampled_from(["duplicate_line", "truncate", "insert", "encoding", "nest", "none"]))
    if kind == "duplicate_line":   # a key given twice (or a stray value: invalid JSON)
        i = draw(st.integers(0, len(lines) - 1))
        line = lines[i].rstrip("\n")
        lines.insert(i, line if line.rstrip().endswith(",") else line + ",\n")
        data = "".join(lines).encode()
    elif kind == "truncate":
        data = text.encode()[:draw(st.integers(0, len(text) - 1))]
    elif kind == "insert":
        i = draw(st.integers(0, len(text)))
        data = text.encode()[:i] + draw(st.binary(min_size=1, max_size=8)) + text.encode()[i:]
    elif kind == "encoding":
        data = text.encode(draw(st.sampled_from(["utf-16", "utf-16-le", "utf-32", "utf-8-sig", "latin-1"])))
    elif kind == "nest":
        depth = draw(st.sampled_from([10, 500, 5000, 100000]))
        data = (text[:-2] + ', "x": ' + "[" * depth + "]" * depth + "}").encode()
    else:
        data = text.encode()
    return data


@fuzz_settings(300)
@given(data=damaged_texts())
def test_damaged_scene_files_load_or_explain(data, renders):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scene.json"
        path.write_bytes(data)
        load_or_explain(lambda: clrender.load_scene(path), renders,
                        lambda e: e.where or str(path) in e.message)   # a JSON path, else the file


# ---------------------------------------------------------------------------------------------
# Mesh files
# ---------------------------------------------------------------------------------------------
def mostly(valid, hostile, odds=8):
    """`valid` values, with one hostile value in about `odds` draws."""
    return st.one_of(*[valid] * (odds - 1), hostile)


def sometimes(draw, valid, hostile):
    """Half the files are clean (they must load and render), half carry a few defects."""
    return hostile if draw(st.booleans(), label="defective") else valid


FLOATS_IN_FILES = mostly(st.floats(-3, 3), st.sampled_from(["nan", "inf", "-inf", "1e39", "1e-45", "0", "-0",
                                                              "1e300", "1e-300", "x", ""]))


@st.composite
def obj_files(draw):
    floats = sometimes(draw, st.floats(-3, 3), FLOATS_IN_FILES)
    vertices = draw(st.lists(sometimes(draw, st.lists(floats, min_size=3, max_size=3), st.lists(
        floats, min_size=3, max_size=3) | st.lists(floats, min_size=2, max_size=4)), min_size=3, max_size=8))
    index = sometimes(draw, st.integers(1, len(vertices)), mostly(st.integers(1, len(vertices)), st.integers(-10, 10)))
    triangle = st.lists(index, min_size=3, max_size=3)
    faces = draw(st.lists(sometimes(draw, triangle, mostly(triangle, st.lists(index, min_size=2, max_size=5))),
                          min_size=sometimes(draw, 1, 0), max_size=8))
    lines = ["v " + " ".join(str(x) for x in v) for v in vertices]
    lines += ["f " + " ".join(str(i) for i in f) for f in faces]
    if draw(st.booleans()):
        lines.insert(draw(st.integers(0, len(lines))), draw(st.sampled_from(
            ["vn 0 0 1", "vt 0 0", "o part", "g", "usemtl none", "s 1", "# comment", "\x00", "f"])))
    return ("\n".join(lines) + "\n").encode()


@st.composite
def damaged(draw, content):
    """`content`, or half the time cut short, with bytes overwritten, or both."""
    if not draw(st.booleans(), label="defective"):
        return content
    content = bytearray(content[:draw(st.integers(0, len(content)))] if draw(st.booleans()) else content)
    for _ in range(draw(st.integers(0, 3))):
        if content:
            content[draw(st.integers(0, len(content) - 1))] = draw(st.integers(0, 255))
    return bytes(content)


@st.composite
def serialized_files(draw):
    """Mitsuba serialized files (versions 3 and 4, any flags, several shapes), often damaged."""
    shapes = []
    for _ in range(draw(st.integers(1, 3))):
        count = draw(st.integers(3, 6))
        values = draw(st.lists(st.floats(-3, 3, width=32), min_size=11 * count, max_size=11 * count))
        columns = np.array(values).reshape(count, 11)
        shapes.append({"positions": columns[:, :3], "double": draw(st.booleans()),
                       "normals": columns[:, 3:6] if draw(st.booleans()) else None,
                       "uvs": columns[:, 6:8] if draw(st.booleans()) else None,
                       "colors": columns[:, 8:] if draw(st.booleans()) else None,
                       "faces": draw(st.lists(st.lists(st.integers(0, count - 1), min_size=3, max_size=3),
                                              min_size=1, max_size=4))})
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "mesh.serialized"
        write_serialized(path, shapes, draw(st.sampled_from([3, 4])))
        return draw(damaged(path.read_bytes()))


@st.composite
def binary_ply_files(draw):
    """Binary PLY files (either byte order, polygons of any size), often damaged."""
    count = draw(st.integers(3, 6))
    vertex = {name: ("float", draw(st.lists(st.floats(-3, 3, width=32), min_size=count, max_size=count)))
              for name in ("x", "y", "z", "u", "v")}
    faces = draw(st.lists(st.lists(st.integers(0, count - 1), min_size=3, max_size=5), min_size=1, max_size=4))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "mesh.ply"
        write_ply_file(path, draw(st.sampled_from(["binary_little_endian", "binary_big_endian"])), vertex, faces,
                       extra_element=draw(st.booleans()))
        return draw(damaged(path.read_bytes()))


@st.composite
def mesh_files(draw):
    kind = draw(st.sampled_from(["obj", "obj", "stl", "ply", "off", "serialized", "binary_ply"]))
    if kind == "obj":
        return "mesh.obj", draw(obj_files())
    if kind == "serialized":
        return "mesh.serialized", draw(serialized_files())
    if kind == "binary_ply":
        return "mesh.ply", draw(binary_ply_files())
    if kind == "stl":   # binary: 80-byte header, a triangle count, 50 bytes per triangle
        count = draw(st.integers(0, 4))
        floats = draw(st.lists(st.floats(width=32), min_size=12 * count, max_size=12 * count))
        body = b"".join(struct.pack("<12fH", *floats[12 * i:12 * i + 12], 0) for i in range(count))
        claimed = draw(st.sampled_from([count, count + 1, 2**31]))
        return "mesh.stl", b"\0" * 80 + struct.pack("<I", claimed) + body
    if kind == "off":
        v = draw(st.integers(0, 5))
        text = f"OFF\n{v} {draw(st.integers(0, 3))} 0\n" + "".join(
            " ".join(str(x) for x in draw(st.lists(FLOATS_IN_FILES, min_size=3, max_size=3))) + "\n" for _ in range(v))
        text += "".join("3 " + " ".join(str(i) for i in draw(st.lists(st.integers(-1, 6), min_size=3, max_size=3)))
                        + "\n" for _ in range(draw(st.integers(0, 3))))
        return "mesh.off", text.encode()
    v = draw(st.integers(0, 4))
    text = (f"ply\nformat ascii 1.0\nelement vertex {v}\nproperty float x\nproperty float y\nproperty float z\n"
            f"element face {draw(st.integers(0, 2))}\nproperty list uchar int vertex_indices\nend_header\n")
    text += "".join(" ".join(str(x) for x in draw(st.lists(FLOATS_IN_FILES, min_size=3, max_size=3))) + "\n"
                    for _ in range(v))
    text += "".join("3 " + " ".join(str(i) for i in draw(st.lists(st.integers(-1, 5), min_size=3, max_size=3)))
                    + "\n" for _ in range(draw(st.integers(0, 2))))
    return "mesh.ply", text.encode()


@fuzz_settings(300)
@given(file=mesh_files(), smooth=st.booleans())
def test_generated_mesh_files_load_or_explain(file, smooth, renders):
    name, content = file
    scene = {"camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "resolution": [4, 4]},
             "materials": [{"name": "m", "type": "diffuse"}],
             "shapes": [{"type": "mesh", "file": name, "material": "m", "smooth": smooth}],
             "lights": [{"type": "environment", "radiance": 1}]}
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / name).write_bytes(content)
        load_or_explain(lambda: clrender.load_scene_dict(scene, base_dir=folder), renders,
                        lambda e: e.where in ("shapes[0].file", "shapes[0]"))


# ---------------------------------------------------------------------------------------------
# Grid files
# ---------------------------------------------------------------------------------------------
GRID_VALUES = mostly(st.floats(0, 10), st.sampled_from([math.nan, math.inf, -1.0, 1e39, 1e300, 1e-300]), odds=30)


@st.composite
def grid_files(draw):
    kind = draw(st.sampled_from(["npy", "npz", "vol", "vol", "vol_header"]))
    rank = draw(mostly(st.just(3), st.integers(0, 4)))
    shape = tuple(draw(st.lists(mostly(st.integers(1, 4), st.just(0), odds=12), min_size=rank, max_size=rank)))
    count = int(np.prod(shape, dtype=np.int64)) if shape else 1
    values = np.array(draw(st.lists(sometimes(draw, st.floats(0, 10), GRID_VALUES), min_size=count,
                                    max_size=count)), dtype=float).reshape(shape)
    dtype = draw(mostly(st.sampled_from(["float32", "float64"]),
                        st.sampled_from(["float16", "int8", "uint16", "complex64", "bool"]), odds=4))
    with np.errstate(all="ignore"):
        array = values.astype(dtype)
    if kind in ("npy", "npz"):
        import io
        buffer = io.BytesIO()
        if kind == "npy":
            np.save(buffer, array)
        else:
            names = draw(st.sampled_from([["density"], ["other"], ["a", "b"], ["density", "b"]]))
            np.savez(buffer, **{n: array for n in names})
        return f"grid.{kind}", buffer.getvalue()
    nz, ny, nx = (list(shape) + [1, 1, 1])[:3] if kind == "vol" else draw(
        st.lists(st.sampled_from([-1, 0, 1, 2, 2**20, 2**31 - 1]), min_size=3, max_size=3))
    header = struct.pack("<3sBiiiii6f", draw(mostly(st.just(b"VOL"), st.just(b"VOX"))),
                         draw(mostly(st.just(3), st.just(2))), draw(mostly(st.just(1), st.just(2))), nx, ny, nz,
                         draw(mostly(st.just(1), st.just(3))), 0, 0, 0, 1, 1, 1)
    with np.errstate(all="ignore"):
        data = np.asarray(values, "<f4").tobytes()
    return "grid.vol", header + data[:draw(mostly(st.just(len(data)), st.integers(0, len(data) + 8)))]


@fuzz_settings(300)
@given(file=grid_files())
def test_generated_grid_files_load_or_explain(file, renders):
    name, content = file
    scene = {"camera": {"position": [0.5, 0.5, 4], "look_at": [0.5, 0.5, 0.5], "resolution": [4, 4]},
             "materials": [], "shapes": [], "lights": [{"type": "environment", "radiance": 1}],
             "media": [{"name": "g", "type": "grid", "sigma_t": 2, "albedo": 0.8, "density": {"file": name}}],
             "medium": "g"}
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / name).write_bytes(content)
        load_or_explain(lambda: clrender.load_scene_dict(scene, base_dir=folder), renders,
                        lambda e: e.where.startswith("media[0]"))


# ---------------------------------------------------------------------------------------------
# Mitsuba XML scene files
# ---------------------------------------------------------------------------------------------
def xml_base_scenes():
    """The Cornell box and the Mitsuba comparison scenes (every plugin the reader supports: glass,
    rough conductors, media and their phase functions, a .vol grid, an EXR environment, OBJ and
    PLY meshes, point, directional and area lights), as name -> XML text."""
    cornell = (Path(__file__).resolve().parent.parent / "scenes" / "cornell_box.xml").read_text()
    return {"cornell_box": cornell} | {name: scene() for name, scene in sorted(mitsuba_scenes.SCENES.items())}


XML_SCENES = xml_base_scenes()
XML_VALUES = ["", "x", "0", "-1", "1e39", "1e-45", "nan", "inf", "-inf", "1e400", "99999999999", "2147483648",
              "1, 2", "1, 2, 3, 4", "0, 0, 0", "true", "$undefined", "$spp", "&amp;", "1e308, 0, 0",
              "1e30", "-1e30", "1e-30", "0.5, nan, 1", "cloud.vol", "ball.obj", "sky.exr", "."]
XML_TAGS = ["scene", "shape", "bsdf", "emitter", "medium", "phase", "volume", "sensor", "film", "sampler",
            "integrator", "transform", "float", "integer", "rgb", "point", "ref", "default", "include", "lookat"]
_XML_TAG = re.compile(r"<!--.*?-->|<(/?)([A-Za-z_][\w.-]*)\b[^>]*?(/?)>", re.S)


def xml_elements(text):
    """(start, end, content_start, tag) of every element below the root, in document order:
    `text[start:end]` is the element, `content_start` is where a child may go (None when the
    element is self-closing)."""
    stack, found = [], []
    for match in _XML_TAG.finditer(text):
        if match.group(2) is None:   # a comment
            continue
        closing, tag, empty = match.groups()
        if empty:
            found.append((match.start(), match.end(), None, tag))
        elif not closing:
            stack.append((match.start(), match.end(), tag))
        elif stack:
            start, content, tag = stack.pop()
            found.append((start, match.end(), content, tag))
    root = max(found, key=lambda e: e[1] - e[0])
    return sorted(e for e in found if e is not root)


def nest_badly(text, draw):
    """Well-formed XML whose elements are in the wrong places: an element moved into another
    one (or out to the root), wrapped in an element of another kind, or its tag renamed."""
    elements = xml_elements(text)
    start, end, _, tag = draw(st.sampled_from(elements))
    moved = text[start:end]
    kind = draw(st.sampled_from(["move", "wrap", "rename"]))
    if kind == "rename":
        other = draw(st.sampled_from(XML_TAGS))
        renamed = re.sub(rf"^<{tag}\b", f"<{other}", moved)
        return text[:start] + re.sub(rf"</{tag}>$", f"</{other}>", renamed) + text[end:]
    if kind == "wrap":
        other = draw(st.sampled_from(XML_TAGS))
        return text[:start] + f'<{other} type="diffuse" name="reflectance">{moved}</{other}>' + text[end:]
    rest = text[:start] + text[end:]
    targets = [e[2] for e in xml_elements(rest) if e[2] is not None] + [rest.index(">", rest.index("<scene")) + 1]
    at = draw(st.sampled_from(sorted(targets)))
    return rest[:at] + moved + rest[at:]


@st.composite
def damaged_xml(draw):
    """A Mitsuba XML scene with an attribute value replaced, a line duplicated, deleted or moved,
    elements nested wrongly, bytes inserted, or the text cut short; sometimes -D parameters of
    any value. Returns the bytes and the parameters."""
    text = XML_SCENES[draw(st.sampled_from(sorted(XML_SCENES)))]
    kind = draw(st.sampled_from(["value", "value", "value", "duplicate_line", "delete_line", "move_line",
                                 "nest", "nest", "insert", "truncate", "none"]))
    if kind == "value":
        values = [m.span(1) for m in re.finditer(r'\b(?:value|name|type|id|x|y|z|angle|origin|target|up)="([^"]*)"', text)]
        start, end = draw(st.sampled_from(values))
        text = text[:start] + draw(st.one_of(st.sampled_from(XML_VALUES), st.text(max_size=6))) + text[end:]
    elif kind in ("duplicate_line", "delete_line", "move_line"):
        lines = text.splitlines(keepends=True)
        i = draw(st.integers(0, len(lines) - 1))
        line = lines.pop(i)
        if kind != "delete_line":
            lines.insert(draw(st.integers(0, len(lines))) if kind == "move_line" else i, line)
        text = "".join(lines)
    elif kind == "nest":
        text = nest_badly(text, draw)
    data = text.encode("utf-8", "surrogatepass")
    if kind == "insert":
        i = draw(st.integers(0, len(data)))
        data = data[:i] + draw(st.binary(min_size=1, max_size=8)) + data[i:]
    elif kind == "truncate":
        data = data[:draw(st.integers(0, len(data) - 1))]
    parameters = draw(mostly(st.just({}), st.dictionaries(st.sampled_from(["spp", "res", "resolution", "max_depth"]),
                                                          st.sampled_from(XML_VALUES), max_size=2), odds=4))
    return data, parameters


@pytest.fixture(scope="module")
def xml_folder(tmp_path_factory):
    """A folder with the files the XML scenes use (meshes, grid, environment map)."""
    folder = tmp_path_factory.mktemp("xml")
    mitsuba_scenes.write(folder, "meshes")
    return folder


def names_xml_line(error, data):
    """The error's place is `scene.xml:LINE`, LINE a line of the file (then the element, for
    errors found after parsing; an XML name: a letter or _, then letters, digits, _ - . or :)."""
    match = re.match(r"scene\.xml:(\d+)(?: <[A-Za-z_][\w.:-]*\b.*>)?$", error.where, re.S)
    return match and 1 <= int(match.group(1)) <= data.count(b"\n") + 1


@fuzz_settings(400)
@given(file=damaged_xml())
def test_damaged_mitsuba_xml_scenes_load_or_explain(file, xml_folder, renders):
    renders.every = 3   # about a fifth load: spread the renders over the run
    """A damaged XML scene fails with an error at its XML line and element (a value that becomes
    an invalid scene field names the field too), or renders finite."""
    import warnings

    data, parameters = file
    path = xml_folder / "scene.xml"
    path.write_bytes(data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # MitsubaXmlWarnings about approximations
        load_or_explain(lambda: clrender.load_scene(path, parameters=parameters), renders,
                        lambda e: names_xml_line(e, data))


# ---------------------------------------------------------------------------------------------
# Round 2 (issue 26): XML include graphs, $name chains and encodings; batch and AOV output sets;
# scheduler stand-ins; signals at random points. Each example has a time bound.
# ---------------------------------------------------------------------------------------------
XML_ENCODINGS = [None, "utf-8", "UTF-8", "latin-1", "utf-16", "shift_jis", "rot13", "no-such-codec", "x" * 300]
XML_DEFAULT_VALUES = ["x", "$a", "$b", "$a$b", "$c$c$c$c", "$undefined", "8", "$a" * 50, "y" * 2000, ""]


@st.composite
def xml_include_graphs(draw):
    """The Cornell box with up to 4 more files: each file includes others (cycles, self-includes
    and diamonds included, some several times), sets <default>s whose values use $name (chains
    and repetition), declares an encoding, and may hold a <bsdf> with an id with a newline.
    Returns {file name: bytes} (scene.xml the main one) and -D parameters."""
    count = draw(st.integers(1, 4))
    files = {}
    for index in range(count + 1):
        lines = []
        for _ in range(draw(st.integers(0, 3))):
            name, value = draw(st.sampled_from("abc")), draw(st.sampled_from(XML_DEFAULT_VALUES))
            lines.append(f'<default name="{name}" value="{value}"/>')
        for _ in range(draw(st.integers(0, 3))):
            target = draw(st.integers(1, count))
            lines += [f'<include filename="f{target}.xml"/>'] * draw(st.integers(1, 3))
        if draw(st.booleans()):
            identifier = draw(st.sampled_from(["$a", "x&#10;clrender: error: forged", "$b$c", "plain"]))
            lines.append(f'<bsdf type="diffuse" id="{identifier}"/>')
        encoding = draw(st.sampled_from(XML_ENCODINGS))
        declaration = f'<?xml version="1.0" encoding="{encoding}"?>\n' if encoding else ""
        body = "\n".join(lines)
        if index == 0:
            text = re.sub(r"(<scene[^>]*>)", lambda m: m.group(1) + "\n" + body + "\n", XML_SCENES["cornell_box"], 1)
            text = re.sub(r"^<\?xml[^>]*\?>\s*", "", text)
            name = "scene.xml"
        else:
            text, name = f'<scene version="3.0.0">\n{body}\n</scene>\n', f"f{index}.xml"
        files[name] = (declaration + text).encode("utf-8")
    parameters = draw(mostly(st.just({}), st.dictionaries(st.sampled_from("abc"), st.sampled_from(XML_DEFAULT_VALUES),
                                                          max_size=2), odds=3))
    return files, parameters


def a_printable_line_at_a_file_line(error):
    """One printable line, short, whose place is FILE.xml:LINE (then the element, if any)."""
    text = str(error)
    return (text.isprintable() and len(text) <= 2 * 2000
            and re.match(r"(scene|f\d)\.xml:\d+(?: <.*>)?$", error.where) is not None)


@fuzz_settings(60)
@given(graph=xml_include_graphs())
def test_xml_include_graphs_parameters_and_encodings_load_or_explain_in_bounded_time(graph, tmp_path_factory,
                                                                                     monkeypatch, renders):
    """With the limits made small (64 includes, 20000 characters of substitution) so that
    hitting them is cheap: every graph loads, or fails with a printable error at a file's line,
    within 5 s."""
    import warnings

    from clrender import limits

    monkeypatch.setattr(limits, "MAX_XML_INCLUDES", 64)
    monkeypatch.setattr(limits, "MAX_SUBSTITUTED_CHARS", 20000)
    files, parameters = graph
    folder = tmp_path_factory.mktemp("graph")
    for name, data in files.items():
        (folder / name).write_bytes(data)
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        load_or_explain(lambda: clrender.load_scene(folder / "scene.xml", parameters=parameters), renders,
                        a_printable_line_at_a_file_line)
    assert time.perf_counter() - start < 5


def cli(*args):
    """(exit code, stderr) of the CLI in this process (test_errors.run_cli)."""
    from test_errors import run_cli

    return run_cli(*args)


def file_state(folder):
    return {path: path.read_bytes() for path in folder.rglob("*") if path.is_file()}


def named_outputs(output, scene_paths, layers):
    """The files a render command names as outputs (docs/distributed.md: a folder holds
    STEM.exr, a pattern names {stem} and {index}; 8-bit formats write NAME.LAYER.png beside)."""
    folder = output.endswith("/") or (len(scene_paths) > 1 and Path(output).is_dir())
    pattern = str(Path(output) / "{stem}.exr") if folder else output
    images = [Path(pattern.format(stem=p.stem, index=i)) for i, p in enumerate(scene_paths)]
    sides = [image.with_name(f"{image.stem}.{layer}{image.suffix}") for image in images for layer in layers
             if image.suffix != ".exr"]
    return {os.path.realpath(p) for p in images + sides}


@st.composite
def output_sets(draw):
    """Scene names (same stems in two folders, stems that are another's side file, a scene
    whose name is an image), an output (folder, patterns, a scene file itself), AOVs, and the
    files that exist before the run."""
    names = draw(st.lists(st.sampled_from(["a.json", "b.json", "a.albedo.json", "sub/a.json", "0.json", "a.png",
                                           "a.normal.png"]), min_size=1, max_size=3, unique=True))
    output = draw(st.sampled_from(["{stem}.png", "{stem}.exr", "out/", "{index}.png", "o.png", "a.png",
                                   "{stem}.albedo.png", "a.normal.png", "sub/{stem}.png"]))
    aovs = draw(st.sampled_from([(), ("albedo",), ("albedo", "normal")]))
    existing = draw(st.lists(st.sampled_from(["a.png", "b.png", "a.albedo.png", "0.png", "out/a.exr", "o.png",
                                              "sub/a.png", "a.normal.png", "keep.txt"]), unique=True, max_size=4))
    return names, output, aovs, existing


@fuzz_settings(15)
@given(case=output_sets())
def test_batch_and_aov_outputs_never_replace_a_file_not_named_as_an_output(case, tmp_path_factory):
    """Every file that existed before the run is untouched, or an output the user named; a scene
    file is never written; a run that succeeds wrote every image it names."""
    names, output, aovs, existing = case
    folder = tmp_path_factory.mktemp("outputs")
    data = json.loads((Path(__file__).parent.parent / "scenes" / "cornell_box.json").read_text())
    data["camera"]["resolution"] = [4, 4]
    scene = json.dumps(data)
    scene_paths = []
    for name in names:
        path = folder / name
        if path.exists():   # "a.png" both a scene and an existing file: the scene
            continue
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(scene)
        scene_paths.append(path)
    for name in existing:
        path = folder / name
        if not path.exists():
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(b"the user's file " + name.encode())
    before = file_state(folder)
    output_path = str(folder / output)
    start = time.perf_counter()
    code, stderr = cli("render", *scene_paths, "-o", output_path, "--spp", "1", "--quiet",
                       *(("--aov", ",".join(aovs)) if aovs else ()))
    assert time.perf_counter() - start < 60
    assert code in (0, 2, 5) and "Traceback" not in stderr, stderr
    named = named_outputs(output_path, scene_paths, aovs) if code == 0 or "{" in output or "/" in output else set()
    for path, data in before.items():
        if path.read_bytes() != data:
            assert code == 0 and os.path.realpath(path) in named and path not in scene_paths, (path, stderr)
    if code == 0:
        assert all(Path(p).exists() for p in named)
    event(f"exit {code}")


@fuzz_settings(10)
@given(kind=st.sampled_from(["silent", "http", "garbage", "close", "stall", "refused"]),
       garbage=st.binary(min_size=1, max_size=40), timeout=st.sampled_from([0.3, 0.6]))
def test_scheduler_stand_ins_fail_with_exit_4_naming_the_address_within_the_time_out(kind, garbage, timeout,
                                                                                     tmp_path_factory):
    """A socket on 127.0.0.1 that never answers, answers as a web server, sends random bytes,
    closes at once, sends half a handshake, or is not there."""
    import socket
    import threading

    pytest.importorskip("distributed")
    server = socket.create_server(("127.0.0.1", 0))
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    payload = {"http": b"HTTP/1.1 400 Bad Request\r\n\r\n", "garbage": garbage,
               "stall": struct.pack("<Q", 64) + garbage[:8]}.get(kind)

    def serve():
        try:
            connection, _ = server.accept()
            if kind == "http":
                connection.recv(4096)
            if payload:
                connection.sendall(payload)
            if kind == "close":
                connection.close()
            time.sleep(timeout + 3)
        except OSError:
            pass

    if kind == "refused":
        server.close()
    else:
        threading.Thread(target=serve, daemon=True).start()
    folder = tmp_path_factory.mktemp("stand_in")
    (folder / "s.json").write_text((Path(__file__).parent.parent / "scenes" / "cornell_box.json").read_text())
    start = time.perf_counter()
    code, stderr = cli("render", folder / "s.json", "-o", folder / "o.png", "--quiet", "--scheduler", address,
                       "--connect-timeout", str(timeout))
    server.close()
    assert code == 4 and f"scheduler at {address}" in stderr and stderr.count("\n") == 1, stderr
    assert time.perf_counter() - start < timeout + 5 and not (folder / "o.png").exists()


@pytest.fixture(scope="module")
def scheduler():
    """The address of a LocalCluster of one worker process, for the CLI's --scheduler."""
    distributed = pytest.importorskip("distributed")
    import logging

    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  silence_logs=logging.ERROR) as cluster:
        yield cluster.scheduler_address


SIGNALS = [signal.SIGINT, signal.SIGTERM, signal.SIGHUP]


@fuzz_settings(8)
@given(mode=st.sampled_from(["local", "batch", "distributed batch", "local cluster"]),
       delay=st.floats(0.0, 4.0), signals=st.lists(st.sampled_from(SIGNALS), min_size=1, max_size=2),
       gap=st.sampled_from([0.0, 0.01, 0.2]))
def test_signals_at_any_point_leave_files_named_or_untouched(mode, delay, signals, gap, tmp_path_factory, scheduler):
    """A render, a batch, a distributed batch or a batch on a local cluster of its own (--workers),
    signalled once or twice after `delay` seconds:
    no traceback (but Python's own, for a Ctrl-C during its start-up, before clrender's main); it
    exits 0, 128 + the first signal, or (before clrender's handlers are in place) of that signal
    (signals that arrive together: any of them); every file that existed before is untouched or a named output, nothing is
    half-written, and a partial image it reports saved loads."""
    folder = tmp_path_factory.mktemp("signals")
    base = json.loads((Path(__file__).parent.parent / "scenes" / "cornell_box.json").read_text())
    base["camera"]["resolution"] = [16, 12]
    scenes = []
    for name, spp in (("first", 1), ("second", 10 ** 6))[:1 if mode == "local" else 2]:
        scene = {**base, "render": {**base.get("render", {}), "spp": spp}}
        (folder / f"{name}.json").write_text(json.dumps(scene))
        scenes.append(folder / f"{name}.json")
    if mode == "local":
        (folder / "first.json").write_text(json.dumps({**base, "render": {**base.get("render", {}), "spp": 10 ** 6}}))
    (folder / "out").mkdir()
    (folder / "out" / "second.png").write_bytes(b"an older image")
    (folder / "notes.txt").write_text("not an output")
    before = file_state(folder)
    cluster = {"distributed batch": ("--scheduler", scheduler, "--chunk-seconds", "0.2"),
               "local cluster": ("--workers", "1", "--chunk-seconds", "0.2")}.get(mode, ())
    process = subprocess.Popen([sys.executable, "-m", "clrender.cli", "render", *map(str, scenes), "-o",
                                str(folder / "out" / "{stem}.png"), "--quiet", *cluster],
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))   # as in a terminal
    time.sleep(delay)
    for signum in signals:
        process.send_signal(signum)
        time.sleep(gap)
    try:
        _, stderr = process.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        process.kill()
        raise AssertionError("still running 60 s after the signals")
    # Signals pending together are handled in signal number order: any of those sent may be "first".
    assert process.returncode in {0} | {128 + s for s in signals} | {-s for s in signals}, stderr
    # -SIGINT: an interrupt before clrender's main (Python's own start-up, where Python prints
    # its KeyboardInterrupt traceback; main catches every one after) is Python's.
    assert "Traceback" not in stderr or process.returncode == -signal.SIGINT, stderr
    named = {folder / "out" / f"{p.stem}.png" for p in scenes}
    after = file_state(folder)
    for path, data in before.items():
        assert after.get(path) == data or path in named, path
    assert set(after) <= set(before) | named, sorted(set(after) - set(before))   # no temporary files left
    for path in named:
        if f"{path}: " in stderr and "partial image saved" in stderr.split(f"{path}: ")[1].splitlines()[0]:
            assert clrender.load_image(path).shape == (12, 16, 3)
    event(f"{mode}: exit {process.returncode}")
