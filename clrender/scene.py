"""Scenes as data: dataclasses, JSON loading and validation.

Every error names its place in the scene file (``shapes[3].material: unknown material 'wite'``).
docs/scene-format.md documents each field, its default and valid range.
"""
import json
import numbers
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import grids, limits, meshes, shapes_cache, textures
from .principled import Principled, read_principled
from .errors import ArgumentError, FileError, SceneError
from .conductor_presets import CONDUCTOR_PRESETS
from .layout import ENVIRONMENT_LOOKUPS, MASKINGS, MICROFACET_DISTRIBUTIONS
from .aovs import parse_aovs
from .files import describe, not_a_file, resolved
from .image_prefetch import ImagePrefetch
from .loader import LoadedScene, load_scene, path_argument, read_scene_bytes

MATERIAL_TYPES = ("diffuse", "emissive", "dielectric", "conductor", "toon", "interface", "thin_dielectric",
                  "plastic", "principled")
SHAPE_TYPES = ("mesh", "sphere", "rectangle", "box", "disk")
LIGHT_TYPES = ("environment", "point", "spot", "directional")
MEDIUM_TYPES = ("homogeneous", "grid")
VOLUME_METHODS = ("null", "raymarch")
SAMPLERS = ("sobol", "independent")   # clrender/layout.py SAMPLERS, kernels/rng.h
FILTER_TYPES = ("box", "gaussian", "tent")   # clrender/filters.py
FILTER_METHODS = ("splat", "importance")     # render.filter_method: kernels/splat.h, kernels/filter.h
# Filter radii up to the image edges the kernel's tables cover (layout.FILTER_EDGES); a filter
# narrower than MIN_FILTER_RADIUS of a pixel is a box in all but name.
MAX_FILTER_RADIUS = 16.0
MIN_FILTER_RADIUS = 0.01
INTEGRATORS = ("path", "direct")
MAX_TOON_BANDS = 32
MESH_SUFFIXES = (".obj", ".ply", ".serialized", ".gltf", ".glb", ".stl", ".off")


def _norm(v):
    """Euclidean length without overflow or underflow of the squares."""
    largest = np.max(np.abs(v))
    return float(largest * np.linalg.norm(v / largest)) if largest > 0 else 0.0


def _unit(v):
    largest = np.max(np.abs(v))
    return (v / largest) / np.linalg.norm(v / largest)


@dataclass(frozen=True)
class Filter:
    """The pixel reconstruction filter (clrender/filters.py, kernels/filter.h)."""
    type: str = "box"          # FILTER_TYPES
    stddev: float = 0.5        # gaussian, pixels (its radius is 4 stddev)
    radius: float = 1.0        # tent, pixels


@dataclass
class Camera:
    position: np.ndarray
    look_at: np.ndarray
    up: np.ndarray
    fov: float                 # vertical field of view, degrees
    resolution: tuple          # (width, height)
    filter: Filter = field(default_factory=Filter)
    # A thin lens (Mitsuba's thinlens; kernels/camera.h): aperture radius (0: a pinhole) and the
    # distance of the plane in focus along the view direction.
    aperture_radius: float = 0.0
    focus_distance: float = 1.0

    def basis(self):
        """(forward, right, up): the unit view direction, and the image's right and up axes
        scaled so that forward + sx * right + sy * up, sx and sy in [-1, 1], spans the image."""
        forward = _unit(self.look_at - self.position)
        right = _unit(np.cross(forward, _unit(self.up)))
        up = np.cross(right, forward)
        tan_half = np.tan(np.radians(self.fov) / 2)
        width, height = self.resolution
        return forward, right * tan_half * width / height, up * tan_half

    def pixel_directions(self, x, y):
        """Unit directions through image positions (x, y) in pixels (0, 0 = top-left corner)."""
        forward, right, up = self.basis()
        width, height = self.resolution
        sx = 2 * np.asarray(x, float) / width - 1
        sy = 1 - 2 * np.asarray(y, float) / height
        d = forward + sx[..., None] * right + sy[..., None] * up
        return d / np.linalg.norm(d, axis=-1, keepdims=True)


@dataclass
class Toon:
    """Cel-shading parameters of a `toon` material (docs/materials-toon.md; kernels/materials/toon.h).

    The defaults give the classic formula C' x (specular + light_intensity + ambient + rim), with
    C' = C x shadow_factor where the light is blocked; shadow_color and bands extend it."""
    ambient: np.ndarray = field(default_factory=lambda: np.full(3, 0.1))   # added once, any lights
    shadow_factor: float = 0.1       # fraction of the colour a point keeps where the light is blocked
    shadow_color: np.ndarray = field(default_factory=lambda: np.ones(3))  # tints that fraction
    bands: int = 1                   # lit tones of light_intensity (1: the formula's two tones)
    softness: float = 0.01           # smoothstep width of each band edge, in N.L
    highlight_size: float = 0.02     # highlight where R.V > 1 - size (0: none)
    highlight_softness: float = 0.005
    highlight_color: np.ndarray = field(default_factory=lambda: np.ones(3))
    rim_threshold: float = 0.25      # rim where N.V < threshold (0: none)
    rim_width: float = 0.02
    rim_color: np.ndarray = field(default_factory=lambda: np.full(3, 0.5))


@dataclass
class Material:
    name: str
    type: str
    albedo: np.ndarray = field(default_factory=lambda: np.full(3, 0.8))  # toon: base color
    emission: np.ndarray = field(default_factory=lambda: np.zeros(3))
    toon: Toon = None                # set for type "toon" only
    # dielectric and conductor (docs/materials-dielectric.md)
    tint: np.ndarray = field(default_factory=lambda: np.ones(3))
    reflection_tint: np.ndarray = field(default_factory=lambda: np.ones(3))   # dielectrics' and plastic's reflection
    # conductor: complex index of refraction per RGB channel; 0 and 0: Fresnel 1 (a tinted mirror)
    conductor_eta: np.ndarray = field(default_factory=lambda: np.zeros(3))
    conductor_k: np.ndarray = field(default_factory=lambda: np.zeros(3))
    ior: float = 1.5            # index of refraction inside (the side the normals point away from)
    exterior_ior: float = 1.0   # index of refraction outside
    roughness: float = 0.0      # 0: smooth (delta lobes); microfacet alpha = roughness^2
    distribution: str = "ggx"   # of rough lobes' normals: layout.MICROFACET_DISTRIBUTIONS
    masking: str = "height_correlated"   # layout.MASKINGS ("separable": Mitsuba's G1(wo) G1(wi))
    # plastic (kernels/materials/plastic.h): albedo is its diffuse_reflectance, reflection_tint its
    # specular_reflectance, ior / exterior_ior, roughness and distribution its coat's (masking:
    # separable, Mitsuba's)
    nonlinear: bool = False     # internal scattering per channel (Mitsuba's `nonlinear`)
    principled: Principled = None   # set for type "principled" only (albedo: its base_color)
    # Mitsuba's conventions (docs/mitsuba-xml.md): a diffuse or conductor material that is not
    # two-sided is black seen from behind its front face; energy_compensation off leaves a rough
    # lobe single-scattering, as Mitsuba's roughdielectric and roughconductor are.
    two_sided: bool = True
    energy_compensation: bool = True
    # Parameters driven by textures: device field (layout.TEXTURABLE_FIELDS: "color" for the
    # albedo, tint or colour, "alpha" for the roughness as Mitsuba's microfacet width,
    # "emission", "opacity") -> index into Scene.textures.
    textures: dict = field(default_factory=dict)
    # Surface wrappers (Mitsuba's mask, bumpmap, normalmap, twosided with two BSDFs): the fraction
    # of light the surface stops (the rest passes straight through); a height field (texture
    # index, -1 none) scaled by bump_scale, or a tangent-space normal map, bending the shading
    # normal; the material seen from behind (index into Scene.materials, -1: this one).
    opacity: float = 1.0
    bump_map: int = -1
    bump_scale: float = 1.0
    normal_map: int = -1
    back: int = -1

    @property
    def index_matched(self):
        """A dielectric with the same index on both sides (compared in float32, as the kernel
        would): no reflection, no refraction, only its tint. It is rendered as an `interface`
        boundary, so it costs no path vertex and shadow rays pass it."""
        return self.type == "dielectric" and np.float32(self.ior) == np.float32(self.exterior_ior)


@dataclass
class Shape:
    name: str
    material: int              # index into Scene.materials
    mesh: meshes.Mesh          # or a meshes.Sphere (analytic)
    interior: int = -1         # medium behind the front faces (index into Scene.media; -1 none)
    exterior: int = -1         # medium in front of the front faces


@dataclass
class Medium:
    """Participating medium; coefficients per RGB channel, scale applied. A `grid` medium's
    coefficients are per unit density: sigma(x) = density(x) * sigma (docs/heterogeneous-media.md)."""
    name: str
    sigma_a: np.ndarray
    sigma_s: np.ndarray
    g: float = 0.0
    type: str = "homogeneous"
    grid: grids.DensityGrid = None   # set for type "grid" only
    # A grid medium's single-scattering albedo per point: (nz, ny, nx, 1 or 3) float32 in [0, 1]
    # filling the density grid's unit cube (sigma_s(x) = albedo(x) sigma_t(x)); sigma_s then
    # holds sigma_t and sigma_a is 0.
    albedo_grid: np.ndarray = None
    # Next-event estimation at scattering vertices inside the medium (Mitsuba's sample_emitters):
    # off where no light can reach them that way, e.g. a medium sealed in glass, whose shadow rays
    # the glass would stop; paths then find emitters by phase sampling alone.
    sample_emitters: bool = True

    @property
    def sigma_t(self):
        return self.sigma_a + self.sigma_s


@dataclass
class Light:
    type: str
    radiance: np.ndarray       # environment radiance, point or spot intensity or directional irradiance
    position: np.ndarray = None
    direction: np.ndarray = None   # directional: the direction the light travels; spot: its axis
    image: np.ndarray = None       # environment: (H, W, 3) linear lat-long image, or None
    lookup: str = "texel"          # environment image: layout.ENVIRONMENT_LOOKUPS name
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))   # environment image: its frame's axes in the world
    cutoff_angle: float = None     # spot: degrees from the axis where its light ends
    beam_width: float = None       # spot: degrees from the axis where its light starts to fall off


@dataclass
class RenderSettings:
    spp: int = 16
    max_depth: int = 8
    rr_depth: int = 5
    seed: int = 0
    # Grid media only (docs/heterogeneous-media.md): "null" (null-scattering path integral,
    # unbiased) or "raymarch" (biased preview; steps of at most `step` voxels, shorter where the
    # medium is dense: see kernels/media/raymarch.h).
    volume_method: str = "null"
    step: float = 2.0
    raymarch_multiple_scattering: bool = True
    hide_environment: bool = False   # camera rays that escape see black
    # Mitsuba's hide_emitters: camera rays also pass through emitting shapes (kernels/path.h).
    hide_emitters: bool = False
    # "path" (path tracing) or "direct" (Mitsuba's direct integrator: at the first hit,
    # emitter_samples light samples and bsdf_samples BSDF samples, balanced by MIS; kernels/direct.h).
    integrator: str = "path"
    emitter_samples: int = 1
    bsdf_samples: int = 1
    aovs: tuple = ()                 # AOVs written with the image unless the render names others
    # Random numbers of camera paths: "sobol" (padded Owen-scrambled Sobol, stratified per
    # pixel) or "independent" (hashed i.i.d. numbers); kernels/rng.h.
    sampler: str = "sobol"
    # How the pixel filter (camera.filter) makes pixels of samples: "splat" (each sample counts
    # in every pixel its filter reaches, as Mitsuba does; kernels/splat.h) or "importance" (each
    # sample's position drawn from its own pixel's filter; kernels/filter.h). The same image in
    # expectation; splatting has less noise per pixel, importance sampling uncorrelated noise.
    filter_method: str = "splat"
    # Caustics (light -> delta surfaces -> non-delta ...) traced from the lights, the path tracer
    # leaving them out (clrender/light_paths.py), where the scene allows.
    light_paths: bool = True
    # Diffuse sampling guided towards the caustics of directional lights through glossy glass and
    # metal (clrender/guide.py), where the scene has them.
    caustic_guide: bool = True


@dataclass
class Outlines:
    """Ink outlines drawn from the auxiliary buffers (clrender/outlines.py)."""
    enabled: bool = False
    width: float = 1.5               # line width in pixels
    color: np.ndarray = field(default_factory=lambda: np.zeros(3))  # linear RGB ink
    depth_threshold: float = 0.1     # relative depth jump (beyond the surface's slope) = silhouette
    crease_angle: float = 30.0       # degrees between neighbouring normals = crease (180: none)


@dataclass
class Scene:
    camera: Camera
    materials: list
    shapes: list
    lights: list
    render: RenderSettings
    media: list = field(default_factory=list)
    medium: int = -1               # scene-wide medium around everything (-1: vacuum)
    camera_medium: int = None      # medium at the camera; None: found by casting a ray
    path: Path = None
    outlines: Outlines = field(default_factory=Outlines)
    origins: object = None         # read from another format: where its fields came from (origins.Origins)
    textures: list = field(default_factory=list)   # textures.Texture, named by materials

    def transform(self, matrix):
        """Move everything (shapes, camera, point and directional lights) by an affine 4x4 matrix."""
        linear, offset = matrix[:3, :3], matrix[:3, 3]
        for shape in self.shapes:
            shape.mesh = meshes.apply_transform(shape.mesh, matrix)
        self.camera.position = linear @ self.camera.position + offset
        self.camera.look_at = linear @ self.camera.look_at + offset
        self.camera.up = linear @ self.camera.up
        lengths = abs(np.linalg.det(linear)) ** (1 / 3)   # the lens's, under a uniform scale
        self.camera.aperture_radius *= lengths
        self.camera.focus_distance *= lengths
        for light in self.lights:
            if light.position is not None:
                light.position = linear @ light.position + offset
            if light.direction is not None:
                light.direction = linear @ light.direction
                light.direction /= np.linalg.norm(light.direction)
        return self

    @property
    def environment(self):
        return next((light for light in self.lights if light.type == "environment"), None)

    def used_material_indices(self):
        """The indices of the materials some shape shows: its own and the one seen from behind it."""
        used = {shape.material for shape in self.shapes}
        return sorted(used | {self.materials[i].back for i in used if self.materials[i].back >= 0})

    def used_materials(self):
        return [self.materials[i] for i in self.used_material_indices()]

    def bounds(self):
        """(min, max) corners of all geometry; a unit box around the origin if there is none."""
        if not self.shapes:
            return -np.ones(3), np.ones(3)
        corners = [meshes.bounds(s.mesh) for s in self.shapes]
        return np.min([lo for lo, _ in corners], axis=0), np.max([hi for _, hi in corners], axis=0)


# --------------------------------------------------------------------------------------------
# Field readers: each checks one value and raises SceneError naming its place.
# --------------------------------------------------------------------------------------------
_MISSING = object()


def _json_kind(value):
    """The JSON name of a value's type, for messages."""
    for kind, name in ((bool, "true/false"), (type(None), "null"), (dict, "an object"), (list, "a list"),
                       (str, "a string"), (numbers.Number, "a number")):
        if isinstance(value, kind):
            return name
    return type(value).__name__


class _Node:
    """A JSON object with its place in the file, for reading fields with checks."""

    def __init__(self, data, where):
        if not isinstance(data, dict):
            raise SceneError(where, f"must be an object, got {_json_kind(data)}")
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
        """A number the device can hold (clrender/limits.py), within [low, high]."""
        value = self.raw(key, default)
        if value is default and default is not _MISSING:
            return value
        return limits.number(value, self.at(key), SceneError, low, high, low_open, integer)

    def setting(self, key, default):
        """A render setting bounded as the CLI flag and the API parameter of that name are."""
        value = self.raw(key, default)
        return value if value is default else limits.setting(key, value, self.at(key), SceneError)

    def vector(self, key, default=_MISSING, size=3, non_negative=False, allow_scalar=False):
        value = self.raw(key, default)
        if value is default and default is not _MISSING:
            return None if default is None else np.asarray(default, dtype=float)
        if allow_scalar and isinstance(value, numbers.Real) and not isinstance(value, bool):
            value = [value] * size
        if not (isinstance(value, list) and len(value) == size):
            raise SceneError(self.at(key), f"must be a list of {size} numbers, got {limits.show(value)}")
        array = np.array([limits.number(x, self.at(key), SceneError) for x in value], dtype=float)
        if non_negative and np.any(array < 0):
            raise SceneError(self.at(key), f"must be non-negative, got {limits.show(value)}")
        return array

    def string(self, key, default=_MISSING, choices=None):
        value = self.raw(key, default)
        if not isinstance(value, str):
            raise SceneError(self.at(key), f"must be a string, got {limits.show(value)}")
        if choices is not None and value not in choices:
            raise SceneError(self.at(key), f"unknown value {limits.show(value)}; valid: {', '.join(choices)}")
        return value

    def boolean(self, key, default=False):
        value = self.raw(key, default)
        if not isinstance(value, bool):
            raise SceneError(self.at(key), f"must be true or false, got {limits.show(value)}")
        return value

    def child(self, key, default=_MISSING):
        value = self.raw(key, default)
        return _Node(value, self.at(key))

    def items(self, key):
        value = self.raw(key, [])
        if not isinstance(value, list):
            raise SceneError(self.at(key), f"must be a list, got {_json_kind(value)}")
        return [_Node(item, f"{self.at(key)}[{i}]") for i, item in enumerate(value)]

    def finish(self):
        """Reject fields nobody read: a typo must not be silently ignored."""
        unknown = [key for key in self.data if key not in self.read]
        if unknown:
            raise SceneError(self.at(unknown[0]), "unknown field")


# --------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------
def as_scene(scene):
    """A Scene from a Scene, a dict with the JSON structure, or the path of a scene file."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, dict):
        return load_scene_dict(scene)
    if isinstance(scene, (str, os.PathLike)):
        return load_scene(scene)
    raise ArgumentError("scene", f"must be a Scene, a scene dict or a file path, got {type(scene).__name__}")


def read_scene_file(path, parameters=None):
    """The JSON scene file `path` (clrender.loader's reader of clrender's own format)."""
    if parameters:
        raise ArgumentError("parameters", f"apply to Mitsuba XML scenes only, not to {path}")
    scene = load_scene_dict(read_json(path), base_dir=path.parent)
    scene.path = path
    return LoadedScene(scene)


_BOMS = {b"\xff\xfe\x00\x00": "UTF-32", b"\x00\x00\xfe\xff": "UTF-32", b"\xff\xfe": "UTF-16",
         b"\xfe\xff": "UTF-16"}


def read_json(path):
    """The JSON document in the file `path` (UTF-8, a byte-order mark allowed), with objects that
    remember duplicated keys; SceneError naming the file for anything else."""
    text = _decode(read_scene_bytes(path), path)
    try:
        document = json.loads(text, object_pairs_hook=_JsonObject.from_pairs)
    except json.JSONDecodeError as e:
        raise SceneError("", f"{path}: invalid JSON at line {e.lineno} column {e.colno}: {e.msg}") from None
    except RecursionError:
        raise SceneError("", f"{path}: nested too deeply to read") from None
    except ValueError as e:   # e.g. an integer of more than 4300 digits
        raise SceneError("", f"{path}: invalid JSON: {e}") from None
    duplicate = _first_duplicate_key(document)
    if duplicate is not None:
        raise SceneError(duplicate, "duplicate key (given more than once in the object)")
    return document


def _decode(data, path):
    for bom, encoding in _BOMS.items():
        if data.startswith(bom):
            raise SceneError("", f"{path} is {encoding}-encoded: save it as UTF-8")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line = data[:e.start].count(b"\n") + 1
        raise SceneError("", f"{path} is not UTF-8 (byte 0x{data[e.start]:02x} on line {line}): "
                             "save it as UTF-8") from None


class _JsonObject(dict):
    """A JSON object that remembers the keys given more than once (the last value is kept)."""
    duplicates = ()

    @classmethod
    def from_pairs(cls, pairs):
        obj = cls(pairs)
        if len(obj) < len(pairs):
            seen = set()
            obj.duplicates = [key for key, _ in pairs if key in seen or seen.add(key)]
        return obj


def _first_duplicate_key(document):
    """The JSON path of the first duplicated key, in document order, or None."""
    stack = [(document, "")]
    while stack:
        value, where = stack.pop()
        if isinstance(value, dict):
            if getattr(value, "duplicates", ()):
                key = value.duplicates[0]
                return f"{where}.{key}" if where else key
            stack.extend(reversed([(v, f"{where}.{k}" if where else k) for k, v in value.items()]))
        elif isinstance(value, list):
            stack.extend(reversed([(v, f"{where}[{i}]") for i, v in enumerate(value)]))
    return None


def load_scene_dict(data, base_dir="."):
    """Build a Scene from a dict with the JSON scene structure (see docs/scene-format.md)."""
    base_dir = path_argument(base_dir, "base_dir")
    root = _Node(data, "")
    with ImagePrefetch() as images:
        _start_image_reads(data, base_dir, images)
        return _read_scene(root, base_dir, images)


def _read_scene(root, base_dir, images):
    camera = _read_camera(root.child("camera"))
    render = _read_render(root.child("render", {}))
    # Textures are read after the shapes, so that their images decode while the meshes load
    # (image_prefetch.py); the materials need their names only.
    texture_nodes = root.items("textures")
    texture_names = [node.data.get("name") for node in texture_nodes]
    material_nodes = root.items("materials")
    material_names = [node.data.get("name") for node in material_nodes]   # `back` may name a later one
    materials = [_read_material(node, texture_names, material_names) for node in material_nodes]
    names = [m.name for m in materials]
    for i, name in enumerate(names):
        if names.index(name) != i:
            raise SceneError(f"materials[{i}].name", f"duplicate material name {name!r}")
    _check_back_materials(materials)
    media = [_read_medium(node, base_dir) for node in root.items("media")]
    medium_names = [m.name for m in media]
    for i, name in enumerate(medium_names):
        if medium_names.index(name) != i:
            raise SceneError(f"media[{i}].name", f"duplicate medium name {name!r}")
    scene_medium = _medium_reference(root, "medium", medium_names)
    shapes = _read_shapes(root.items("shapes"), names, medium_names, scene_medium, base_dir)
    texture_list = [_read_texture(node, base_dir, images) for node in texture_nodes]
    _unique_names(texture_list, "textures")
    lights = [_read_light(node, base_dir, images) for node in root.items("lights")]
    if sum(light.type == "environment" for light in lights) > 1:
        raise SceneError("lights", "at most one environment light is allowed")
    camera_medium = None
    if "medium" in root.data["camera"]:
        camera_medium = _medium_reference(_Node(root.data["camera"], "camera"), "medium", medium_names)
    outlines = _read_outlines(root.child("outlines")) if "outlines" in root.data else Outlines()
    root.finish()
    _check_grid_media_are_placed(media, shapes, scene_medium, camera_medium)
    _check_direct_integrator(render, materials, media)
    return Scene(camera, materials, shapes, lights, render, media, scene_medium, camera_medium,
                 outlines=outlines, textures=texture_list)


def _start_image_reads(data, base_dir, images):
    """Begin decoding the texture and environment image files that `data` names (the readers
    below ask `images` for them where they read them). Whatever looks wrong is left to them."""
    from .image import load_image, load_texture_image

    def file_of(item, kind):
        """The resolved path of an item of type `kind` that names a file, else None."""
        if isinstance(item, dict) and item.get("type") == kind and isinstance(item.get("file"), str):
            try:
                return resolved(base_dir / item["file"])
            except (OSError, ValueError):   # an unreadable name: the reader says so at its place
                return None
        return None

    for item in data.get("textures") if isinstance(data.get("textures"), list) else []:
        path, raw = file_of(item, "bitmap"), item.get("raw", False) if isinstance(item, dict) else False
        if path is not None and isinstance(raw, bool):
            images.start(("bitmap", path, raw), load_texture_image, path, raw=raw)
    for item in data.get("lights") if isinstance(data.get("lights"), list) else []:
        path = file_of(item, "environment")
        if path is not None:
            images.start(("environment", path), load_image, path)


def _unique_names(items, where):
    """The names of `items` (with .name), each given once (SceneError at the second)."""
    names = [item.name for item in items]
    for i, name in enumerate(names):
        if names.index(name) != i:
            raise SceneError(f"{where}[{i}].name", f"duplicate name {name!r}")
    return names


def _read_camera(node):
    width, height = _resolution(node)
    camera = Camera(
        position=node.vector("position"),
        look_at=node.vector("look_at"),
        up=node.vector("up", [0, 1, 0]),
        fov=node.number("fov", 40.0, low=0, high=179, low_open=True),
        resolution=(width, height),
        filter=_read_filter(node.child("filter")) if "filter" in node.data else Filter(),
        aperture_radius=float(node.number("aperture_radius", 0.0, low=0)),
    )
    node.read.add("medium")  # read with the media, which come later in the file
    forward = camera.look_at - camera.position
    if _norm(forward) == 0:
        raise SceneError(node.at("look_at"), "must differ from camera.position")
    camera.focus_distance = float(node.number("focus_distance", _norm(forward), low=0, low_open=True))
    if _norm(camera.up) == 0 or _norm(np.cross(_unit(forward), _unit(camera.up))) <= 1e-9:
        raise SceneError(node.at("up"), "must not be zero or parallel to the viewing direction")
    node.finish()
    return camera


def _read_filter(node):
    kind = node.string("type", choices=FILTER_TYPES)
    d = Filter()
    if kind == "gaussian":   # its radius is 4 stddev
        f = Filter(kind, stddev=float(node.number("stddev", d.stddev, low=MIN_FILTER_RADIUS / 4,
                                                  high=MAX_FILTER_RADIUS / 4)))
    elif kind == "tent":
        f = Filter(kind, radius=float(node.number("radius", d.radius, low=MIN_FILTER_RADIUS, high=MAX_FILTER_RADIUS)))
    else:
        f = Filter(kind)
    node.finish()
    return f


def _resolution(node):
    value = node.raw("resolution", [256, 256])
    if not (isinstance(value, list) and len(value) == 2 and all(
            isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= limits.MAX_RESOLUTION for v in value)):
        raise SceneError(node.at("resolution"), f"must be [width, height], integers in "
                                                f"1..{limits.MAX_RESOLUTION}, got {limits.show(value)}")
    return tuple(value)


def _read_render(node):
    settings = RenderSettings(
        spp=node.setting("spp", 16),
        max_depth=node.setting("max_depth", 8),
        rr_depth=node.setting("rr_depth", 5),
        seed=node.setting("seed", 0),
        volume_method=node.string("volume_method", "null", choices=VOLUME_METHODS),
        step=float(node.setting("step", 2.0)),
        raymarch_multiple_scattering=node.boolean("raymarch_multiple_scattering", True),
        hide_environment=node.boolean("hide_environment", False),
        hide_emitters=node.boolean("hide_emitters", False),
        sampler=node.string("sampler", "sobol", choices=SAMPLERS),
        filter_method=node.string("filter_method", "splat", choices=FILTER_METHODS),
        light_paths=node.boolean("light_paths", True),
        caustic_guide=node.boolean("caustic_guide", True),
        integrator=node.string("integrator", "path", choices=INTEGRATORS),
        aovs=_read_aovs(node),
    )
    if settings.integrator == "direct":
        settings.emitter_samples, settings.bsdf_samples = (
            node.number(key, 1, low=0, high=limits.MAX_SHADING_SAMPLES, integer=True)
            for key in ("emitter_samples", "bsdf_samples"))
        if settings.emitter_samples + settings.bsdf_samples == 0:
            raise SceneError(node.at("emitter_samples"), "and bsdf_samples are both 0: the direct integrator "
                                                         "needs a sample of one technique")
    node.finish()
    return settings


def _check_direct_integrator(render, materials, media):
    """The direct integrator renders surfaces lit by emitters, as Mitsuba's: no media (Mitsuba's
    ignores them) and no toon shading (a path-tracer vertex of its own)."""
    if render.integrator != "direct":
        return
    if media or any(m.type == "interface" or m.index_matched for m in materials):
        raise SceneError("render.integrator", "'direct' renders no media: remove the media and interfaces "
                                              "(index-matched dielectrics are interfaces), or use 'path'")
    if any(m.type == "toon" for m in materials):
        raise SceneError("render.integrator", "'direct' does not render toon materials: use 'path'")


def _read_aovs(node):
    value = node.raw("aovs", [])
    if not (isinstance(value, list) and all(isinstance(name, str) for name in value)):
        raise SceneError(node.at("aovs"), f"must be a list of AOV names, got {limits.show(value)}")
    try:
        return parse_aovs(value)
    except ArgumentError as e:
        raise SceneError(node.at("aovs"), e.message) from None


def _read_material(node, texture_names=(), material_names=()):
    name = node.string("name")
    kind = node.string("type", choices=MATERIAL_TYPES)
    maps = {}
    texturable = _TexturableReader(node, texture_names, maps)
    if kind == "diffuse":
        material = Material(name, kind, albedo=texturable.color("albedo", "color", [0.8, 0.8, 0.8], high=1,
                                                                       allow_scalar=False),
                            emission=texturable.color("emission", "emission", [0, 0, 0], allow_scalar=False),
                            two_sided=node.boolean("two_sided", True))
    elif kind == "toon":
        material = Material(name, kind, albedo=texturable.color("color", "color", [0.8, 0.8, 0.8], high=1),
                            toon=_read_toon(node))
    elif kind == "principled":
        material = Material(name, kind, albedo=texturable.color("base_color", "color", [0.5] * 3, high=1),
                            principled=read_principled(node, texturable), energy_compensation=False)
    elif kind == "emissive":
        material = Material(name, kind, albedo=np.zeros(3),
                            emission=texturable.color("radiance", "emission", allow_scalar=True))
    elif kind in ("dielectric", "conductor"):
        material = Material(name, kind, albedo=np.zeros(3), tint=texturable.color("tint", "color", [1.0] * 3, high=1),
                            roughness=_read_roughness(node, texturable),
                            distribution=node.string("distribution", "ggx", choices=MICROFACET_DISTRIBUTIONS),
                            masking=node.string("masking", "height_correlated", choices=MASKINGS),
                            emission=texturable.color("emission", "emission", [0, 0, 0], allow_scalar=False))
        material.energy_compensation = node.boolean("energy_compensation", "alpha" not in maps)
        if material.energy_compensation and "alpha" in maps:
            raise SceneError(node.at("energy_compensation"), "needs a constant roughness, not a texture")
        if kind == "conductor":
            material.two_sided = node.boolean("two_sided", True)
            material.conductor_eta, material.conductor_k = _read_conductor_ior(node)
        if kind == "dielectric":
            _read_dielectric_sides(node, texturable, material)
    elif kind == "thin_dielectric":
        material = Material(name, kind, albedo=np.zeros(3), tint=texturable.color("tint", "color", [1.0] * 3, high=1))
        _read_dielectric_sides(node, texturable, material)
    elif kind == "plastic":
        material = _read_plastic(node, name, texturable)
    else:  # an index-matched boundary: only separates media
        material = Material(name, kind, albedo=np.zeros(3))
    if kind in ("thin_dielectric", "plastic", "principled"):   # emitting, as an area emitter on any BSDF in Mitsuba
        material.emission = texturable.color("emission", "emission", [0, 0, 0], allow_scalar=False)
    if kind != "interface":
        _read_surface_wrappers(node, texturable, material, texture_names, material_names)
    material.textures = maps
    node.finish()
    return material


def _read_dielectric_sides(node, texturable, material):
    """The indices of refraction inside and outside, and the tint of reflection."""
    material.ior = node.number("ior", 1.5, low=0, low_open=True)
    material.exterior_ior = node.number("exterior_ior", 1.0, low=0, low_open=True)
    material.reflection_tint = texturable.color("reflection_tint", "reflection_tint", [1.0] * 3, high=1)


def _read_conductor_ior(node):
    """A conductor's complex index of refraction (eta, k) per RGB channel: `eta` and `k`, or a
    preset `material` (Mitsuba's names), or neither: (0, 0), Fresnel reflectance 1."""
    if "material" in node.data:
        if "eta" in node.data or "k" in node.data:
            raise SceneError(node.where, "give either material or eta and k")
        name = node.string("material", choices=CONDUCTOR_PRESETS)
        return tuple(np.array(value, dtype=float) for value in CONDUCTOR_PRESETS[name])
    if ("eta" in node.data) != ("k" in node.data):
        raise SceneError(node.at("k" if "eta" in node.data else "eta"), "required with "
                         f"{'eta' if 'eta' in node.data else 'k'} (the complex index eta + i k)")
    return (node.vector("eta", [0.0] * 3, non_negative=True, allow_scalar=True),
            node.vector("k", [0.0] * 3, non_negative=True, allow_scalar=True))


def _read_plastic(node, name, texturable):
    """Mitsuba's plastic and roughplastic, with their defaults (polypropylene in air)."""
    material = Material(name, "plastic",
                        albedo=texturable.color("diffuse", "color", [0.5] * 3, high=1),
                        reflection_tint=texturable.color("specular", "reflection_tint", [1.0] * 3, high=1),
                        roughness=_read_roughness(node, texturable),
                        distribution=node.string("distribution", "ggx", choices=MICROFACET_DISTRIBUTIONS),
                        masking="separable", ior=node.number("ior", 1.49, low=0, low_open=True),
                        exterior_ior=node.number("exterior_ior", 1.000277, low=0, low_open=True),
                        nonlinear=node.boolean("nonlinear", False), two_sided=node.boolean("two_sided", True))
    if np.float32(material.ior) == np.float32(material.exterior_ior):
        raise SceneError(node.at("ior"), "must differ from exterior_ior (a coat that is no interface)")
    return material


def _read_surface_wrappers(node, texturable, material, texture_names, material_names):
    """`opacity`, `bump` or `normal_map`, and `back`, which any surface material may have."""
    material.opacity = float(texturable.number("opacity", "opacity", 1.0, low=0, high=1))
    if "bump" in node.data and "normal_map" in node.data:
        raise SceneError(node.where, "give either bump or normal_map")
    if "bump" in node.data:
        bump = node.child("bump")
        material.bump_map = _texture_index(bump, texture_names)
        material.bump_scale = float(bump.number("scale", 1.0))
        bump.finish()
    if "normal_map" in node.data:
        normal_map = node.child("normal_map")
        material.normal_map = _texture_index(normal_map, texture_names)
        normal_map.finish()
    if "back" in node.data:
        back = node.string("back")
        if back not in material_names:
            raise SceneError(node.at("back"), f"unknown material {back!r}; defined: "
                                              f"{', '.join(n for n in material_names if isinstance(n, str))}")
        material.back = material_names.index(back)


def _check_back_materials(materials):
    """A material seen from behind another (Mitsuba's twosided with two BSDFs) is seen from
    behind itself: it must reflect from that side (two-sided) and not transmit, as the front."""
    for index, material in enumerate(materials):
        if material.back < 0:
            continue
        back = materials[material.back]
        where = f"materials[{index}].back"
        if material.back == index:
            raise SceneError(where, "names the material itself")
        for which in (material, back):
            if which.type in ("dielectric", "thin_dielectric", "interface"):
                raise SceneError(where, f"{which.name!r} is a {which.type}: materials with a back must not "
                                        "transmit, nor their back (Mitsuba's twosided)")
        if not back.two_sided:
            raise SceneError(where, f"{back.name!r} is one-sided: seen from behind it would be black")
        if back.back >= 0:
            raise SceneError(where, f"{back.name!r} has a back material of its own")


def _texture_index(node, texture_names):
    """The index of the texture that node["texture"] names."""
    name = node.string("texture")
    if name not in texture_names:
        raise SceneError(node.at("texture"), f"unknown texture {name!r}; defined: "
                                             f"{', '.join(texture_names) or 'none'}")
    return list(texture_names).index(name)


def _read_roughness(node, texturable):
    """`roughness` (perceptual: alpha = roughness^2) or `alpha` (the microfacet width, Mitsuba's;
    a number or a texture), as the roughness."""
    if "roughness" in node.data and "alpha" in node.data:
        raise SceneError(node.where, "give either roughness or alpha")
    if "alpha" in node.data:
        return float(np.sqrt(texturable.number("alpha", "alpha", 0.0, low=0, high=1)))
    return node.number("roughness", 0.0, low=0, high=1)


class _TexturableReader:
    """Reads material parameters that are a constant or {"texture": NAME}; records each texture
    used in `maps` (device field -> texture index)."""

    def __init__(self, node, texture_names, maps):
        self.node, self.texture_names, self.maps = node, list(texture_names), maps

    def _texture(self, key, field):
        """True (and the texture recorded) when node[key] names a texture."""
        value = self.node.data.get(key)
        if not isinstance(value, dict):
            return False
        reference = self.node.child(key)
        self.maps[field] = _texture_index(reference, self.texture_names)
        reference.finish()
        return True

    def color(self, key, field, default=None, high=None, allow_scalar=True):
        """An RGB constant (non-negative, <= high per channel) or a texture (then the default)."""
        if self._texture(key, field):
            return np.ones(3)
        value = self.node.vector(key, _MISSING if default is None else default, non_negative=True,
                                 allow_scalar=allow_scalar)
        if high is not None and np.any(value > high):
            raise SceneError(self.node.at(key), f"must be <= {high} per channel, got {value.tolist()}")
        return value

    def number(self, key, field, default, low=None, high=None):
        """A number in [low, high] or a texture (then the default)."""
        if self._texture(key, field):
            return default
        return self.node.number(key, default, low=low, high=high)


def _unit_color(node, key, default=(1.0, 1.0, 1.0)):
    """An RGB factor with every channel in [0, 1] (a scalar means grey)."""
    color = node.vector(key, list(default), non_negative=True, allow_scalar=True)
    if np.any(color > 1):
        raise SceneError(node.at(key), f"must be <= 1 per channel, got {color.tolist()}")
    return color


def _read_toon(node):
    """Toon parameters; `highlight` and `rim` are optional sub-objects (docs/materials-toon.md)."""
    d = Toon()
    highlight = node.child("highlight", {})
    rim = node.child("rim", {})
    toon = Toon(
        ambient=node.vector("ambient", d.ambient.tolist(), non_negative=True, allow_scalar=True),
        shadow_color=_unit_color(node, "shadow_color", d.shadow_color.tolist()),
        shadow_factor=float(node.number("shadow_factor", d.shadow_factor, low=0, high=1)),
        bands=node.number("bands", d.bands, low=1, high=MAX_TOON_BANDS, integer=True),
        softness=float(node.number("softness", d.softness, low=0, high=1)),
        highlight_size=float(highlight.number("size", d.highlight_size, low=0, high=1)),
        highlight_softness=float(highlight.number("softness", d.highlight_softness, low=0, high=1)),
        highlight_color=highlight.vector("color", d.highlight_color.tolist(), non_negative=True,
                                         allow_scalar=True),
        rim_threshold=float(rim.number("threshold", d.rim_threshold, low=0, high=1)),
        rim_width=float(rim.number("width", d.rim_width, low=0, high=1)),
        rim_color=rim.vector("color", d.rim_color.tolist(), non_negative=True, allow_scalar=True),
    )
    highlight.finish()
    rim.finish()
    return toon


def _read_outlines(node):
    d = Outlines()
    outlines = Outlines(
        enabled=node.boolean("enabled", True),
        width=float(node.number("width", d.width, low=0, high=16, low_open=True)),
        color=node.vector("color", d.color.tolist(), non_negative=True, allow_scalar=True),
        depth_threshold=float(node.number("depth_threshold", d.depth_threshold, low=0, low_open=True)),
        crease_angle=float(node.number("crease_angle", d.crease_angle, low=0, high=180, low_open=True)),
    )
    node.finish()
    return outlines




def _medium_reference(node, key, medium_names):
    """Index of the medium named by node[key], -1 when absent or null."""
    name = node.raw(key, None)
    if name is None:
        return -1
    if not isinstance(name, str) or name not in medium_names:
        raise SceneError(node.at(key), f"unknown medium {name!r}; defined: {', '.join(medium_names) or 'none'}")
    return medium_names.index(name)


def _read_medium(node, base_dir):
    name = node.string("name")
    kind = node.string("type", "homogeneous", choices=MEDIUM_TYPES)
    albedo_grid = _read_albedo_grid(node, base_dir, kind) if "albedo_grid" in node.data else None
    if albedo_grid is not None:
        sigma_s = node.vector("sigma_t", [1, 1, 1], non_negative=True, allow_scalar=True)
        sigma_a = np.zeros(3)
    elif "sigma_t" in node.data or "albedo" in node.data:
        if "sigma_a" in node.data or "sigma_s" in node.data:
            raise SceneError(node.where, "give either sigma_a and sigma_s, or sigma_t and albedo")
        sigma_t = node.vector("sigma_t", non_negative=True, allow_scalar=True)
        albedo = node.vector("albedo", non_negative=True, allow_scalar=True)
        if np.any(albedo > 1):
            raise SceneError(node.at("albedo"), f"must be <= 1 per channel, got {albedo.tolist()}")
        sigma_s = sigma_t * albedo
        sigma_a = sigma_t - sigma_s
    else:
        sigma_a = node.vector("sigma_a", [0, 0, 0], non_negative=True, allow_scalar=True)
        sigma_s = node.vector("sigma_s", [0, 0, 0], non_negative=True, allow_scalar=True)
    scale = node.number("scale", 1.0, low=0)
    g = node.number("g", 0.0)
    if not -1 < g < 1:
        raise SceneError(node.at("g"), f"must be in (-1, 1), got {g!r}")
    sample_emitters = node.boolean("sample_emitters", True)
    grid = _read_grid(node, base_dir) if kind == "grid" else None
    node.finish()
    sigma_a, sigma_s = sigma_a * scale, sigma_s * scale
    limits.float32_values(sigma_a + sigma_s, node.where, SceneError)   # the product with `scale`
    return Medium(name, sigma_a, sigma_s, float(g), kind, grid, albedo_grid, sample_emitters)


def _read_albedo_grid(node, base_dir, kind):
    """A grid medium's `albedo_grid` ({"file": ...}, 1 or 3 channels in [0, 1]), with `sigma_t`."""
    where = node.at("albedo_grid")
    if kind != "grid":
        raise SceneError(where, "only a grid medium takes an albedo grid")
    if any(key in node.data for key in ("albedo", "sigma_a", "sigma_s")):
        raise SceneError(where, "replaces `albedo`: give `sigma_t` only (the albedo grid splits it)")
    file_node = node.child("albedo_grid")
    albedo = _load_grid_file(file_node, base_dir, grids.load_albedo_file)
    file_node.finish()
    return np.ascontiguousarray(albedo)


def _load_grid_file(node, base_dir, load):
    """`load(path)` of the grid file named by node.file (SceneError naming it if that fails)."""
    path = resolved(base_dir / node.string("file"))
    if path.suffix.lower() not in grids.GRID_SUFFIXES:
        raise SceneError(node.at("file"), f"unsupported grid format {path.suffix!r}; "
                                          f"valid: {', '.join(grids.GRID_SUFFIXES)}")
    if not_a_file(path) is not None:
        raise SceneError(node.at("file"), describe(path))
    try:
        return load(path)
    except Exception as e:  # numpy and struct raise many types for malformed files
        raise SceneError(node.at("file"), f"cannot load grid {path}: {e}") from None


def _read_grid(node, base_dir):
    """The density grid of a `grid` medium: `density` (a file or a generator), `transform`
    (the unit cube [0, 1]^3 into the world) and `majorant_block` (voxels per block edge)."""
    density_node = node.child("density")
    density, source = _read_density(density_node, base_dir)
    problem = grids.check_density(density)
    if problem:
        raise SceneError(density_node.where, problem)
    to_world = _read_transform(node.child("transform")) if "transform" in node.data else np.eye(4)
    block = node.number("majorant_block", grids.DEFAULT_BLOCK, low=1, high=1024, integer=True)
    return grids.DensityGrid(np.ascontiguousarray(density, dtype=np.float32), to_world, block, source)


def _read_density(node, base_dir):
    """(array, description) from {"file": ...} or {"procedural": name, "resolution": ..., ...}."""
    if ("file" in node.data) == ("procedural" in node.data):
        raise SceneError(node.where, "give either a `file` or a `procedural` generator")
    if "file" in node.data:
        density = _load_grid_file(node, base_dir, grids.load_density_file)
        path = resolved(base_dir / node.string("file"))
        node.finish()
        return density, path.name
    name = node.string("procedural", choices=tuple(grids.PROCEDURAL))
    value = node.raw("resolution", [32, 32, 32])
    if not (isinstance(value, list) and len(value) == 3 and all(
            isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= 1024 for v in value)):
        raise SceneError(node.at("resolution"), f"must be [nx, ny, nz], integers in 1..1024, got {limits.show(value)}")
    count = value[0] * value[1] * value[2]
    if count > grids.MAX_PROCEDURAL_VOXELS:   # checked before the generator allocates
        raise SceneError(node.at("resolution"), f"{count} voxels, more than the {grids.MAX_PROCEDURAL_VOXELS} "
                                                "a procedural grid may have (use a grid file)")
    options = {}
    for key, (default, kind, low, high) in grids.PROCEDURAL[name][1].items():
        options[key] = node.number(key, default, low=low, high=high, integer=kind is int)
    node.finish()
    return grids.procedural(name, value, **options), f"{name} {value[0]}x{value[1]}x{value[2]}"


def _check_grid_media_are_placed(media, shapes, scene_medium, camera_medium):
    """A grid medium fills the region it is assigned to (top-level `medium`, a shape's interior
    or exterior, or the camera's), with zero density outside its grid box. One assigned nowhere,
    or only to shape interiors that do not overlap its box, could never be seen."""
    for index, medium in enumerate(media):
        if medium.type != "grid":
            continue
        where = f"media[{index}]"
        holders = [s for s in shapes if s.interior == index]
        if index in (scene_medium, camera_medium) or any(s.exterior == index for s in shapes):
            continue
        if not holders:
            raise SceneError(where, f"grid medium {medium.name!r} is used nowhere: make it the top-level "
                                    "`medium` or a shape's `interior` (see docs/scene-format.md, Media)")
        lo, hi = medium.grid.world_bounds()
        if not any(np.all(meshes.bounds(s.mesh)[0] <= hi) and np.all(meshes.bounds(s.mesh)[1] >= lo)
                   for s in holders):
            raise SceneError(where, f"the box of grid medium {medium.name!r} ({lo.round(4).tolist()} to "
                                    f"{hi.round(4).tolist()}) lies outside every shape whose interior it is")


def _read_shapes(nodes, material_names, medium_names, scene_medium, base_dir):
    """The shapes, in one piece from the disk cache where the same descriptions of many shapes
    were read before (shapes_cache.py), else each by _read_shape (and stored)."""
    entry = shapes_cache.key([node.data for node in nodes], [material_names, medium_names, scene_medium], base_dir)
    cached = shapes_cache.load(entry) if entry is not None else None
    if cached is not None:
        return [Shape(*fields) for fields in cached]
    shapes = [_read_shape(node, material_names, medium_names, scene_medium, base_dir) for node in nodes]
    if entry is not None:
        shapes_cache.store(entry, [(s.name, s.material, s.mesh, s.interior, s.exterior) for s in shapes])
    return shapes


def _read_shape(node, material_names, medium_names, scene_medium, base_dir):
    kind = node.string("type", choices=SHAPE_TYPES)
    material_name = node.string("material")
    if material_name not in material_names:
        raise SceneError(node.at("material"),
                         f"unknown material {material_name!r}; defined: {', '.join(material_names) or 'none'}")
    if kind == "mesh":
        mesh = _read_mesh_file(node, base_dir)
    elif kind == "sphere":
        mesh = _read_sphere(node)
    elif kind == "rectangle":
        mesh = meshes.rectangle()
    elif kind == "disk":
        mesh = meshes.disk(node.number("segments", 128, low=3, high=4096, integer=True))
    else:
        mesh = meshes.box()
    if "transform" in node.data:
        matrix = _read_transform(node.child("transform"))
        try:
            mesh = meshes.apply_transform(mesh, matrix)
        except ValueError as e:  # a sphere scaled unevenly
            raise SceneError(node.at("transform"), str(e)) from None
    if node.boolean("flip_normals", False):
        mesh = meshes.flip(mesh)
    mesh = meshes.kept_in_scene(mesh)
    name = node.string("name", f"{kind}{node.where[node.where.index('['):]}")
    interior = _medium_reference(node, "interior", medium_names) if "interior" in node.data else scene_medium
    exterior = _medium_reference(node, "exterior", medium_names) if "exterior" in node.data else scene_medium
    node.finish()
    return Shape(name, material_names.index(material_name), mesh, interior, exterior)


def _read_sphere(node):
    """An analytic sphere, or with `mesh: true` an icosphere (`subdivisions`, `smooth`)."""
    center = node.vector("center", [0, 0, 0])
    radius = node.number("radius", 1.0, low=0, low_open=True)
    if node.boolean("mesh", False):
        return meshes.icosphere(center, radius, node.number("subdivisions", 4, low=0, high=7, integer=True),
                                smooth=node.boolean("smooth", True))
    for key in ("subdivisions", "smooth"):
        if key in node.data:
            raise SceneError(node.at(key), 'applies to tessellated spheres only: add "mesh": true')
    return meshes.Sphere(center, float(radius))


def _read_mesh_file(node, base_dir):
    filename = node.string("file")
    path = resolved(base_dir / filename)
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise SceneError(node.at("file"), f"unsupported mesh format {path.suffix!r}; valid: {', '.join(MESH_SUFFIXES)}")
    if not_a_file(path) is not None:
        raise SceneError(node.at("file"), describe(path))
    shape_index = 0
    if path.suffix.lower() == ".serialized":
        shape_index = node.number("shape_index", 0, low=0, integer=True)
    flip_tex_coords = node.boolean("flip_tex_coords", meshes.FLIP_TEX_COORDS.get(path.suffix.lower(), True))
    try:
        return meshes.load_mesh_file(path, node.boolean("smooth", False), flip_tex_coords, shape_index)
    except Exception as e:  # trimesh raises many types for malformed files
        raise SceneError(node.at("file"), f"cannot load mesh {path}: {e}") from None


def _read_transform(node):
    if "matrix" in node.data:
        value = node.raw("matrix")
        matrix = None
        if _is_matrix(value):
            matrix = _finite_float32_matrix(value)
            if matrix is None:   # some entry is not: its own message
                where = node.at("matrix")
                matrix = np.array([[limits.number(x, where, SceneError) for x in row] for row in value])
        if matrix is None or np.any(matrix[3] != [0, 0, 0, 1]):
            raise SceneError(node.at("matrix"), "must be a 4x4 affine matrix (rows; last row 0 0 0 1)")
    else:
        scale = node.vector("scale", [1, 1, 1], allow_scalar=True)
        matrix = meshes.transform_matrix(node.vector("translate", [0, 0, 0]),
                                         node.vector("rotate", [0, 0, 0]), scale)
    limits.float32_values(matrix, node.where, SceneError)
    singular = np.linalg.svd(matrix[:3, :3], compute_uv=False)
    # Relative to its own scale (a scene in nanometres is fine): flat when the smallest stretch
    # is lost against the largest, which also keeps the inverse (for normals) accurate.
    if not singular[-1] > singular[0] / limits.MAX_TRANSFORM_CONDITION:
        raise SceneError(node.where, f"is singular: it flattens the shape (stretches {singular[0]:.3g} "
                                     f"and {singular[-1]:.3g}, a ratio beyond {limits.MAX_TRANSFORM_CONDITION:g})")
    node.finish()
    return matrix


def _finite_float32_matrix(rows):
    """The matrix of number `rows` as floats when every entry is finite in float32 (as
    limits.number reads each), else None. (A scene of hundreds of shapes has hundreds of matrices.)"""
    try:
        matrix = np.array(rows, float)
    except OverflowError:   # an integer beyond float
        return None
    return matrix if np.all(np.abs(matrix) <= limits.FLOAT32_MAX) else None


def _is_matrix(value):
    return isinstance(value, list) and len(value) == 4 and all(
        isinstance(row, list) and len(row) == 4 and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in row) for row in value)


def _read_texture(node, base_dir, images):
    """A texture (docs/scene-format.md, Textures): a `bitmap` from a `file` (or, from Python, an
    `image` array: uint8 sRGB-encoded unless `raw`, floats linear) or a `checkerboard`."""
    name = node.string("name")
    kind = node.string("type", choices=textures.KINDS)
    texture = textures.Texture(name, kind, to_uv=_read_uv_transform(node))
    if kind == "checkerboard":
        texture.color0 = node.vector("color0", [0.4] * 3, non_negative=True, allow_scalar=True)
        texture.color1 = node.vector("color1", [0.2] * 3, non_negative=True, allow_scalar=True)
    else:
        texture.filter = node.string("filter", "bilinear", choices=textures.FILTERS)
        texture.wrap = node.string("wrap", "repeat", choices=textures.WRAPS)
        raw = node.boolean("raw", False)
        if ("file" in node.data) == ("image" in node.data):
            raise SceneError(node.where, "a bitmap needs either a `file` or an `image`")
        if "file" in node.data:
            texture.pixels, texture.srgb = _texture_file(node, base_dir, raw, images)
            texture.source = node.data["file"]
        else:
            texture.pixels, texture.srgb = _texture_array(node, raw)
    node.finish()
    return texture


def _read_uv_transform(node):
    """`to_uv`: the rows [[a, b, c], [d, e, f]] of the affine map (u, v) -> (a u + b v + c, ...)."""
    value = node.raw("to_uv", None)
    if value is None:
        return np.eye(3)[:2]
    if not (isinstance(value, list) and len(value) == 2 and all(isinstance(row, list) and len(row) == 3 for row in value)):
        raise SceneError(node.at("to_uv"), f"must be 2 rows of 3 numbers, got {limits.show(value)}")
    return np.array([[limits.number(x, node.at("to_uv"), SceneError) for x in row] for row in value])


def _texture_file(node, base_dir, raw, images):
    from .image import load_texture_image

    path = resolved(base_dir / node.string("file"))
    if not_a_file(path) is not None:
        raise SceneError(node.at("file"), describe(path))
    try:
        image = images.get(("bitmap", path, raw), load_texture_image, path, raw=raw)
    except FileError as e:
        raise SceneError(node.at("file"), e.message) from None
    return image.pixels, image.srgb


def _texture_array(node, raw):
    """An (H, W, C) image given from Python, C in 1, 3, 4 (an (H, W) array is grey)."""
    try:
        image = np.asarray(node.raw("image"))
    except ValueError:   # ragged nested lists
        image = np.zeros(0)
    if image.ndim == 2:
        image = image[..., None]
    if (image.ndim != 3 or image.shape[2] not in (1, 3, 4) or min(image.shape[:2]) < 1
            or not (image.dtype == np.uint8 or np.issubdtype(image.dtype, np.floating))):
        raise SceneError(node.at("image"), f"must be an (H, W, C) array of uint8 or floats, C in 1, 3, 4, "
                                           f"got shape {image.shape} of {image.dtype}")
    if image.dtype != np.uint8:
        limits.float32_values(image, node.at("image"), SceneError)
        return image.astype(np.float32), False
    return image, not raw


def _read_light(node, base_dir, images):
    kind = node.string("type", choices=LIGHT_TYPES)
    if kind == "environment":
        light = _read_environment(node, base_dir, images)
    elif kind == "point":
        light = Light(kind, node.vector("intensity", non_negative=True, allow_scalar=True),
                      position=node.vector("position"))
    elif kind == "spot":
        cutoff = float(node.number("cutoff_angle", 20.0, low=0, high=180, low_open=True))
        light = Light(kind, node.vector("intensity", non_negative=True, allow_scalar=True),
                      position=node.vector("position"), direction=_direction(node), cutoff_angle=cutoff,
                      beam_width=float(node.number("beam_width", 0.75 * cutoff, low=0)))
    else:
        light = Light(kind, node.vector("irradiance", non_negative=True, allow_scalar=True),
                      direction=_direction(node))
    node.finish()
    return light


def _direction(node):
    direction = node.vector("direction")
    if _norm(direction) == 0:
        raise SceneError(node.at("direction"), "must be non-zero")
    return _unit(direction)


def _read_environment(node, base_dir, images):
    scale = node.number("scale", 1.0, low=0)
    if sum(key in node.data for key in ("image", "file", "radiance")) > 1:
        raise SceneError(node.where, "give one of radiance, file or image")
    if "image" in node.data:   # Python API: an (H, W, 3) lat-long array instead of a file
        try:
            image = np.asarray(node.raw("image"))
        except ValueError:   # ragged nested lists
            image = np.zeros(0)
        if image.ndim != 3 or image.shape[2] != 3 or min(image.shape[:2]) < 1 or not np.issubdtype(image.dtype, np.number):
            raise SceneError(node.at("image"), f"must be an (H, W, 3) array of numbers, got shape {image.shape}")
        return _environment_image(node, image, "image", scale)
    if "file" in node.data:
        from .image import load_image

        path = resolved(base_dir / node.string("file"))
        if not_a_file(path) is not None:
            raise SceneError(node.at("file"), describe(path))
        try:
            image = images.get(("environment", path), load_image, path)
        except FileError as e:
            raise SceneError(node.at("file"), e.message) from None
        return _environment_image(node, image, "file", scale)
    for key in ("lookup", "transform"):
        if key in node.data:
            raise SceneError(node.at(key), "applies to an environment image (file or image) only")
    radiance = node.vector("radiance", [1, 1, 1], non_negative=True, allow_scalar=True)
    limits.float32_values(radiance * scale, node.at("scale"), SceneError)
    return Light("environment", radiance * scale)


def _environment_image(node, image, key, scale):
    """The environment light of a lat-long image given at `key`: finite and non-negative, and
    times `scale` still finite in float32; looked up as `lookup` says, in the frame `transform`
    turns."""
    limits.float32_values(image, node.at(key), SceneError)
    image = np.asarray(image, dtype=np.float32)
    if image.size and image.min() < 0:
        raise SceneError(node.at(key), "image must be non-negative")
    limits.float32_values(float(image.max()) * scale, node.at("scale"), SceneError)
    lookup = node.string("lookup", "texel", choices=ENVIRONMENT_LOOKUPS)
    if lookup == "mitsuba" and image.shape[0] < 2:
        raise SceneError(node.at(key), "Mitsuba's lookup needs an image of at least 2 rows")
    rotation = np.eye(3)
    if "transform" in node.data:
        rotation = _read_transform(node.child("transform"))[:3, :3]
        if not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-5):
            raise SceneError(node.at("transform"), "must be a rotation (a translation changes nothing)")
    return Light("environment", np.ones(3) * scale, image=image if scale == 1 else image * np.float32(scale),
                 lookup=lookup, rotation=rotation)
