"""Participating media, their phase functions and volumes.

| plugin | parameter (Mitsuba's default) | clrender |
|---|---|---|
| `homogeneous` | `sigma_t` (1), `albedo` (0.75), `scale` (1); or `sigma_a` and `sigma_s` | homogeneous medium |
| `heterogeneous` | `sigma_t` a `gridvolume`, constant `albedo`, `scale` | `grid` medium (a constant sigma_t: homogeneous) |
| accepted | `sample_emitters`, `has_spectral_extinction` (sampling choices) | |
| phase `isotropic` | | `g` 0 |
| phase `hg` | `g` (0.8) | `g` |
| volume `constvolume` | `value` (albedo); `to_world` accepted | a constant |
| volume `gridvolume` | `filename` (.vol), `to_world`, `use_grid_bbox`; trilinear, clamp; `raw`, `accel` accepted | the grid's density file and `transform` |

Where media are: see check_media_nesting.
"""
import numpy as np

from .. import meshes
from ..grids import read_vol
from ..origins import place
from .transforms import matrix_rows
from .xml import MitsubaXmlError

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
    phases = plugin.nested("phase")
    if len(phases) > 1:
        raise plugin.error("a medium takes one phase function")
    medium = {"name": name, "scale": plugin.number("scale", 1.0), "g": read_phase(phases[0] if phases else None, reader)}
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


def read_phase(plugin, reader):
    """Henyey-Greenstein g of a phase function; plugin None: the medium has none (isotropic)."""
    if plugin is None:
        return 0.0
    if plugin.type == "isotropic":
        g = 0.0
    elif plugin.type == "hg":
        g = plugin.number("g", 0.8)
    else:
        raise plugin.error(f"unsupported phase function '{plugin.type}' (supported: isotropic, hg)")
    plugin.finish()
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
    if plugin.type != "gridvolume":
        raise plugin.error(f"unsupported volume '{plugin.type}' for sigma_t (supported: gridvolume)")
    path = plugin.file("filename", reader.files)
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
    return {"type": "grid", "density": {"file": str(path)}, "transform": {"matrix": matrix_rows(matrix)}}


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
                place(translation.origins, f"shapes[{i}]") or f"shapes[{i}]",
                f"this shape declares no interior/exterior but lies inside "
                f"{place(translation.origins, f'shapes[{j}]')}, whose interior is medium "
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
