"""Participating media, their phase functions and volumes.

| plugin | parameter (Mitsuba's default) | clrender |
|---|---|---|
| `homogeneous` | `sigma_t` (1), `albedo` (0.75), `scale` (1); or `sigma_a` and `sigma_s` | homogeneous medium |
| both | `sample_emitters` (true) | `sample_emitters` |
| `heterogeneous` | `sigma_t` a `gridvolume`, `albedo` constant or a `gridvolume` placed as sigma_t's (1 or 3 channels), `scale` | `grid` medium, `albedo_grid` (a constant sigma_t: homogeneous) |
| accepted | `has_spectral_extinction` (a sampling choice) | |
| phase `isotropic` | | `g` 0 |
| phase `hg` | `g` (0.8) | `g` |
| volume `constvolume` | `value` (albedo); `to_world` accepted | a constant |
| volume `gridvolume` | `filename` (.vol), `to_world`, `use_grid_bbox`; trilinear, clamp; `raw`, `accel` accepted | the grid's density file and `transform` (sigma_t); `albedo_grid` (albedo) |
| texture `volume` (as `sigma_t` or `albedo`) | `volume` | a constant: its value at the world origin, as Mitsuba 3.9 evaluates a texture there (a warning) |

Where media are: see check_media_nesting.
"""
import numpy as np

from .. import meshes
from ..grids import read_vol, trilinear
from ..origins import place
from .plugin import Plugin
from .transforms import matrix_rows
from .values import fmt
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
    medium = {"name": name, "scale": plugin.number("scale", 1.0), "g": read_phase(phases[0] if phases else None, reader),
              "sample_emitters": plugin.boolean("sample_emitters", True)}
    plugin.accept("has_spectral_extinction")   # a sampling choice
    if plugin.has("sigma_a") or plugin.has("sigma_s"):
        if plugin.has("sigma_t") or plugin.has("albedo"):
            raise plugin.error("give either sigma_t and albedo, or sigma_a and sigma_s")
        medium["sigma_a"] = plugin.color("sigma_a", 0.0, warnings_).tolist()
        medium["sigma_s"] = plugin.color("sigma_s", 0.0, warnings_).tolist()
    else:
        sigma_t = _read_coefficient(plugin, reader, "sigma_t", 1.0)
        albedo = _read_coefficient(plugin, reader, "albedo", 0.75)
        if isinstance(sigma_t, Plugin):
            if plugin.type != "heterogeneous":
                raise sigma_t.error("a grid sigma_t needs a heterogeneous medium")
            path, matrix = _read_grid_volume(sigma_t, reader)
            medium.update(type="grid", density={"file": str(path)}, transform={"matrix": matrix_rows(matrix)},
                          sigma_t=1.0)
        else:
            medium["sigma_t"] = sigma_t
        if isinstance(albedo, Plugin):
            medium["albedo_grid"] = _read_albedo_grid(albedo, reader, medium.get("transform"))
        else:
            medium["albedo"] = albedo
    plugin.finish()
    reader.out.scene["media"].append(medium)
    reader.medium_names[key] = name
    reader.note(plugin, f"media[{index}]", f"{'grid' if 'density' in medium else 'homogeneous'} '{name}'"
                + (", albedo grid" if "albedo_grid" in medium else ""))
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


def _read_coefficient(plugin, reader, name, default):
    """sigma_t or albedo: a gridvolume (its Plugin), or a constant RGB list (a value, a
    constvolume, or a texture, which Mitsuba evaluates at the world origin)."""
    if plugin.has(name) and plugin.properties[name][0].tag == "texture":
        return _texture_at_origin(plugin.object(name, "texture"), reader, name).tolist()
    volume = plugin.volume(name)
    if volume is None:
        return plugin.color(name, default, reader.out.warnings).tolist()
    return volume if volume.type == "gridvolume" else _constant_volume(volume, reader).tolist()


def _texture_at_origin(texture, reader, name):
    """Mitsuba 3.9 takes a texture where a medium expects a volume by wrapping it in a
    constvolume, which evaluates it at a zeroed interaction: a `volume` texture (as Mitsuba's Lego
    tutorial scene writes one) gives its volume's value at the world origin, everywhere (its
    renders are those of that constant). So does clrender, with a warning."""
    if texture.type != "volume":
        raise texture.error(f"unsupported texture '{texture.type}' for a medium's {name} (supported: a "
                            "volume texture, which Mitsuba evaluates at the world origin)")
    volumes = texture.nested("volume")
    if len(volumes) != 1:
        raise texture.error("a volume texture takes one <volume>")
    texture.finish()
    volume = volumes[0]
    if volume.type != "gridvolume":
        return _constant_volume(volume, reader)
    path, matrix = _read_grid_volume(volume, reader, channels=(1, 3))
    values, _ = read_vol(path, (1, 3))
    values = values.reshape(*values.shape[:3], -1)
    origin = np.clip(np.linalg.solve(matrix, [0.0, 0.0, 0.0, 1.0])[:3], 0.0, 1.0)   # gridvolume clamps
    value = np.array([trilinear(values[..., c], origin[None])[0] for c in range(values.shape[3])])
    value = np.broadcast_to(value, 3).copy()
    reader.warn(f"{texture.element.where()}: a texture as a medium's {name} is its value at the world origin, "
                f"{fmt(value)}, everywhere: Mitsuba 3.9 evaluates it there only (use a <volume> for a grid)")
    return value


def _constant_volume(plugin, reader):
    if plugin.type != "constvolume":
        raise plugin.error(f"unsupported volume '{plugin.type}' (supported: constvolume, gridvolume)")
    value = plugin.color("value", 0.75, reader.out.warnings)
    plugin.accept("to_world")   # a constant does not move
    plugin.finish()
    return value


def _read_albedo_grid(plugin, reader, density_transform):
    """A gridvolume albedo: the `albedo_grid` of a grid medium, which fills the density grid's unit
    cube, so it must be placed as sigma_t's grid is (Mitsuba places each volume by its own
    to_world)."""
    if density_transform is None:
        raise plugin.error("a grid albedo needs a gridvolume sigma_t (clrender's albedo grid fills the density grid's box)")
    path, matrix = _read_grid_volume(plugin, reader, channels=(1, 3))
    if not np.allclose(matrix_rows(matrix), density_transform["matrix"], rtol=1e-6, atol=1e-9):
        raise plugin.error("the albedo grid must be placed as the sigma_t grid is (the same to_world and "
                           "use_grid_bbox, and for use_grid_bbox the same bounding box in the files)")
    return {"file": str(path)}


def _read_grid_volume(plugin, reader, channels=(1,)):
    """gridvolume from a .vol file: (path, the 4x4 placement of the grid's unit cube). Mitsuba puts
    the grid in the unit cube of its to_world (sample (i, j, k) at ((i + 0.5) / nx, ...),
    trilinear, clamped at the faces, zero outside), as clrender/grids.py does; with use_grid_bbox
    the file's bounding box is placed inside to_world instead."""
    if plugin.type != "gridvolume":
        raise plugin.error(f"unsupported volume '{plugin.type}' (supported: gridvolume, and constvolume "
                           "for constants)")
    path = plugin.file("filename", reader.files)
    if path.suffix.lower() != ".vol":
        raise plugin.error(f"gridvolume reads Mitsuba .vol files, got {path.name}")
    matrix = plugin.transform("to_world")
    matrix = np.eye(4) if matrix is None else matrix
    if plugin.boolean("use_grid_bbox", False):
        try:
            _, bbox = read_vol(path, channels)
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
    plugin.accept("raw", "accel")   # no colour conversion in RGB variants; hardware interpolation only
    plugin.finish()
    return path, matrix


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
