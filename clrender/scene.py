"""Scenes as data: dataclasses, JSON loading and validation.

Every error names its place in the scene file (``shapes[3].material: unknown material 'wite'``).
docs/scene-format.md documents each field, its default and valid range.
"""
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import meshes
from .errors import SceneError

MATERIAL_TYPES = ("diffuse", "emissive", "dielectric", "conductor")
SHAPE_TYPES = ("mesh", "sphere", "rectangle", "box")
LIGHT_TYPES = ("environment", "point", "directional")
MESH_SUFFIXES = (".obj", ".ply", ".gltf", ".glb", ".stl", ".off")


@dataclass
class Camera:
    position: np.ndarray
    look_at: np.ndarray
    up: np.ndarray
    fov: float                 # vertical field of view, degrees
    resolution: tuple          # (width, height)


@dataclass
class Material:
    name: str
    type: str
    albedo: np.ndarray = field(default_factory=lambda: np.full(3, 0.8))
    emission: np.ndarray = field(default_factory=lambda: np.zeros(3))
    # dielectric and conductor (docs/dielectric-notes.md)
    tint: np.ndarray = field(default_factory=lambda: np.ones(3))
    ior: float = 1.5            # index of refraction inside (the side the normals point away from)
    exterior_ior: float = 1.0   # index of refraction outside
    roughness: float = 0.0      # 0: smooth (delta lobes); GGX alpha = roughness^2


@dataclass
class Shape:
    name: str
    material: int              # index into Scene.materials
    mesh: meshes.Mesh


@dataclass
class Light:
    type: str
    radiance: np.ndarray       # environment radiance, point intensity or directional irradiance
    position: np.ndarray = None
    direction: np.ndarray = None   # directional: the direction the light travels
    image: np.ndarray = None       # environment: (H, W, 3) linear lat-long image, or None


@dataclass
class RenderSettings:
    spp: int = 16
    max_depth: int = 8
    rr_depth: int = 5
    seed: int = 0


@dataclass
class Scene:
    camera: Camera
    materials: list
    shapes: list
    lights: list
    render: RenderSettings
    path: Path = None

    @property
    def environment(self):
        return next((light for light in self.lights if light.type == "environment"), None)

    def bounds(self):
        """(min, max) corners of all geometry; a unit box around the origin if there is none."""
        if not self.shapes:
            return -np.ones(3), np.ones(3)
        lo = np.min([s.mesh.vertices.min(axis=0) for s in self.shapes], axis=0)
        hi = np.max([s.mesh.vertices.max(axis=0) for s in self.shapes], axis=0)
        return lo, hi


# --------------------------------------------------------------------------------------------
# Field readers: each checks one value and raises SceneError naming its place.
# --------------------------------------------------------------------------------------------
_MISSING = object()


class _Node:
    """A JSON object with its place in the file, for reading fields with checks."""

    def __init__(self, data, where):
        if not isinstance(data, dict):
            raise SceneError(where, f"must be an object, got {type(data).__name__}")
        self.data = data
        self.where = where
        self.read = set()

    def at(self, key):
        return f"{self.where}.{key}" if self.where else key

    def raw(self, key, default=_MISSING):
        self.read.add(key)
        if key not in self.data:
            if default is _MISSING:
                raise SceneError(self.at(key), "is required")
            return default
        return self.data[key]

    def number(self, key, default=_MISSING, low=None, high=None, low_open=False, integer=False):
        value = self.raw(key, default)
        if value is default and default is not _MISSING:
            return value
        kind = "an integer" if integer else "a number"
        if isinstance(value, bool) or not isinstance(value, (int, float)) or (
                integer and not isinstance(value, int)):
            raise SceneError(self.at(key), f"must be {kind}, got {value!r}")
        if not np.isfinite(value):
            raise SceneError(self.at(key), f"must be finite, got {value!r}")
        if low is not None and (value <= low if low_open else value < low):
            raise SceneError(self.at(key), f"must be {'>' if low_open else '>='} {low}, got {value!r}")
        if high is not None and value > high:
            raise SceneError(self.at(key), f"must be <= {high}, got {value!r}")
        return value

    def vector(self, key, default=_MISSING, size=3, non_negative=False, allow_scalar=False):
        value = self.raw(key, default)
        if value is default and default is not _MISSING:
            return None if default is None else np.asarray(default, dtype=float)
        if allow_scalar and isinstance(value, (int, float)) and not isinstance(value, bool):
            value = [value] * size
        ok = isinstance(value, list) and len(value) == size and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in value)
        if not ok:
            raise SceneError(self.at(key), f"must be a list of {size} numbers, got {value!r}")
        array = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(array)):
            raise SceneError(self.at(key), f"must be finite, got {value!r}")
        if non_negative and np.any(array < 0):
            raise SceneError(self.at(key), f"must be non-negative, got {value!r}")
        return array

    def string(self, key, default=_MISSING, choices=None):
        value = self.raw(key, default)
        if not isinstance(value, str):
            raise SceneError(self.at(key), f"must be a string, got {value!r}")
        if choices is not None and value not in choices:
            raise SceneError(self.at(key), f"unknown value {value!r}; valid: {', '.join(choices)}")
        return value

    def boolean(self, key, default=False):
        value = self.raw(key, default)
        if not isinstance(value, bool):
            raise SceneError(self.at(key), f"must be true or false, got {value!r}")
        return value

    def child(self, key, default=_MISSING):
        value = self.raw(key, default)
        return _Node(value, self.at(key))

    def items(self, key):
        value = self.raw(key, [])
        if not isinstance(value, list):
            raise SceneError(self.at(key), f"must be a list, got {type(value).__name__}")
        return [_Node(item, f"{self.at(key)}[{i}]") for i, item in enumerate(value)]

    def finish(self):
        """Reject fields nobody read: a typo must not be silently ignored."""
        unknown = sorted(set(self.data) - self.read)
        if unknown:
            raise SceneError(self.at(unknown[0]), "unknown field")


# --------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------
def load_scene(path):
    """Load and validate a JSON scene file; relative file paths resolve against its folder."""
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise SceneError("", f"scene file not found: {path}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise SceneError("", f"{path}: invalid JSON at line {e.lineno} column {e.colno}: {e.msg}") from None
    scene = load_scene_dict(data, base_dir=path.parent)
    scene.path = path
    return scene


def load_scene_dict(data, base_dir="."):
    """Build a Scene from a dict with the JSON scene structure (see docs/scene-format.md)."""
    base_dir = Path(base_dir)
    root = _Node(data, "")
    camera = _read_camera(root.child("camera"))
    render = _read_render(root.child("render", {}))
    materials = [_read_material(node) for node in root.items("materials")]
    names = [m.name for m in materials]
    for i, name in enumerate(names):
        if names.index(name) != i:
            raise SceneError(f"materials[{i}].name", f"duplicate material name {name!r}")
    shapes = [_read_shape(node, names, base_dir) for node in root.items("shapes")]
    lights = [_read_light(node, base_dir) for node in root.items("lights")]
    if sum(light.type == "environment" for light in lights) > 1:
        raise SceneError("lights", "at most one environment light is allowed")
    root.finish()
    return Scene(camera, materials, shapes, lights, render)


def _read_camera(node):
    width, height = _resolution(node)
    camera = Camera(
        position=node.vector("position"),
        look_at=node.vector("look_at"),
        up=node.vector("up", [0, 1, 0]),
        fov=node.number("fov", 40.0, low=0, high=179, low_open=True),
        resolution=(width, height),
    )
    forward = camera.look_at - camera.position
    if np.linalg.norm(forward) == 0:
        raise SceneError(node.at("look_at"), "must differ from camera.position")
    if np.linalg.norm(np.cross(forward, camera.up)) == 0:
        raise SceneError(node.at("up"), "must not be parallel to the viewing direction")
    node.finish()
    return camera


def _resolution(node):
    value = node.raw("resolution", [256, 256])
    if not (isinstance(value, list) and len(value) == 2 and all(
            isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= 16384 for v in value)):
        raise SceneError(node.at("resolution"), f"must be [width, height], integers in 1..16384, got {value!r}")
    return tuple(value)


def _read_render(node):
    settings = RenderSettings(
        spp=node.number("spp", 16, low=1, integer=True),
        max_depth=node.number("max_depth", 8, low=1, high=1024, integer=True),
        rr_depth=node.number("rr_depth", 5, low=1, integer=True),
        seed=node.number("seed", 0, low=0, high=2**32 - 1, integer=True),
    )
    node.finish()
    return settings


def _read_material(node):
    name = node.string("name")
    kind = node.string("type", choices=MATERIAL_TYPES)
    if kind == "diffuse":
        material = Material(name, kind, albedo=node.vector("albedo", [0.8, 0.8, 0.8], non_negative=True),
                            emission=node.vector("emission", [0, 0, 0], non_negative=True))
        if np.any(material.albedo > 1):
            raise SceneError(node.at("albedo"), f"must be <= 1 per channel, got {material.albedo.tolist()}")
    elif kind == "emissive":
        material = Material(name, kind, albedo=np.zeros(3),
                            emission=node.vector("radiance", non_negative=True, allow_scalar=True))
    else:
        material = Material(name, kind, albedo=np.zeros(3),
                            tint=_unit_color(node, "tint"),
                            roughness=node.number("roughness", 0.0, low=0, high=1))
        if kind == "dielectric":
            material.ior = node.number("ior", 1.5, low=0, low_open=True)
            material.exterior_ior = node.number("exterior_ior", 1.0, low=0, low_open=True)
    node.finish()
    return material


def _unit_color(node, key):
    """An RGB factor in [0, 1] per channel (a scalar means grey), default white."""
    color = node.vector(key, [1.0, 1.0, 1.0], non_negative=True, allow_scalar=True)
    if np.any(color > 1):
        raise SceneError(node.at(key), f"must be <= 1 per channel, got {color.tolist()}")
    return color


def _read_shape(node, material_names, base_dir):
    kind = node.string("type", choices=SHAPE_TYPES)
    material_name = node.string("material")
    if material_name not in material_names:
        raise SceneError(node.at("material"),
                         f"unknown material {material_name!r}; defined: {', '.join(material_names) or 'none'}")
    if kind == "mesh":
        mesh = _read_mesh_file(node, base_dir)
    elif kind == "sphere":
        mesh = meshes.sphere(node.vector("center", [0, 0, 0]),
                             node.number("radius", 1.0, low=0, low_open=True),
                             node.number("subdivisions", 4, low=0, high=7, integer=True),
                             smooth=node.boolean("smooth", True))
    elif kind == "rectangle":
        mesh = meshes.rectangle()
    else:
        mesh = meshes.box()
    if "transform" in node.data:
        mesh = meshes.apply_transform(mesh, _read_transform(node.child("transform")))
    if node.boolean("flip_normals", False):
        mesh = meshes.flip(mesh)
    name = node.string("name", f"{kind}{node.where[node.where.index('['):]}")
    node.finish()
    return Shape(name, material_names.index(material_name), mesh)


def _read_mesh_file(node, base_dir):
    filename = node.string("file")
    path = (base_dir / filename).resolve()
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise SceneError(node.at("file"), f"unsupported mesh format {path.suffix!r}; valid: {', '.join(MESH_SUFFIXES)}")
    if not path.is_file():
        raise SceneError(node.at("file"), f"file not found: {path}")
    try:
        return meshes.load_mesh_file(path, smooth=node.boolean("smooth", False))
    except Exception as e:  # trimesh raises many types for malformed files
        raise SceneError(node.at("file"), f"cannot load mesh {path}: {e}") from None


def _read_transform(node):
    if "matrix" in node.data:
        value = node.raw("matrix")
        matrix = np.asarray(value, dtype=float) if _is_matrix(value) else None
        if matrix is None or not np.all(np.isfinite(matrix)) or np.any(matrix[3] != [0, 0, 0, 1]):
            raise SceneError(node.at("matrix"), "must be a 4x4 affine matrix (rows; last row 0 0 0 1)")
    else:
        scale = node.vector("scale", [1, 1, 1], allow_scalar=True)
        matrix = meshes.transform_matrix(node.vector("translate", [0, 0, 0]),
                                         node.vector("rotate", [0, 0, 0]), scale)
    if abs(np.linalg.det(matrix[:3, :3])) < 1e-30:
        raise SceneError(node.where, "is singular (a zero scale flattens the shape)")
    node.finish()
    return matrix


def _is_matrix(value):
    return isinstance(value, list) and len(value) == 4 and all(
        isinstance(row, list) and len(row) == 4 and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in row) for row in value)


def _read_light(node, base_dir):
    kind = node.string("type", choices=LIGHT_TYPES)
    if kind == "environment":
        light = _read_environment(node, base_dir)
    elif kind == "point":
        light = Light(kind, node.vector("intensity", non_negative=True, allow_scalar=True),
                      position=node.vector("position"))
    else:
        direction = node.vector("direction")
        if np.linalg.norm(direction) == 0:
            raise SceneError(node.at("direction"), "must be non-zero")
        light = Light(kind, node.vector("irradiance", non_negative=True, allow_scalar=True),
                      direction=direction / np.linalg.norm(direction))
    node.finish()
    return light


def _read_environment(node, base_dir):
    scale = node.number("scale", 1.0, low=0)
    if "file" in node.data:
        from .image import load_image

        path = (base_dir / node.string("file")).resolve()
        if not path.is_file():
            raise SceneError(node.at("file"), f"file not found: {path}")
        try:
            image = load_image(path)
        except Exception as e:
            raise SceneError(node.at("file"), f"cannot load image {path}: {e}") from None
        if not np.all(np.isfinite(image)) or np.any(image < 0):
            raise SceneError(node.at("file"), "image must be finite and non-negative")
        return Light("environment", np.ones(3) * scale, image=image * scale)
    radiance = node.vector("radiance", [1, 1, 1], non_negative=True, allow_scalar=True)
    return Light("environment", radiance * scale)
