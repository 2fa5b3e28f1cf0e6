"""Our scenes as Mitsuba 3 scenes (a `mitsuba.load_dict` dictionary), for side-by-side runs.

    description = mitsuba_description(scene, "assets/")   # plain data; meshes and grids as files
    mitsuba_scene = mi.load_dict(to_mitsuba_dict(description, mi))

`mitsuba_description` returns the dictionary with plain Python values only (JSON-serialisable):
each `to_world` is a 4x4 row-major matrix as nested lists, which `to_mitsuba_dict` turns into
`mi.ScalarTransform4f` (load_dict accepts nothing else). Meshes are written as binary PLY files
and density grids as .vol files into the asset folder. tools/peers.py loads this module by its
file path in its timed Mitsuba process, so that process imports Mitsuba only: nothing at module
level here may import clrender.

Conventions made equal (docs/performance.md, "Against Mitsuba 3"): vertical field of view
(`fov_axis` y), the pixel filter (box, gaussian or tent), a thin lens, one-sided area
emitters on the side the triangle winding (or the sphere's outward normal) faces, flat normals
for meshes without shading normals, max depth counted alike (1: emitters only). Russian roulette
starts at our `rr_depth` in both: Mitsuba's `path` starts it at `depth >= rr_depth`, its
`volpath` at `depth > rr_depth`, so volpath gets rr_depth - 1.

Only what has an exact Mitsuba counterpart is exported: diffuse, emissive, smooth dielectric,
smooth conductor and index-matched interfaces, without textures or surface wrappers; homogeneous and grey grid
media (albedo grids too) with Henyey-Greenstein phase; constant environments, point, spot and directional lights.
Anything else
raises ValueError naming the object.
"""
from pathlib import Path

# Per material type: the Mitsuba plugin of a smooth material.
_SPECULAR_PLUGINS = {"dielectric": "dielectric", "conductor": "conductor"}


def mitsuba_description(scene, asset_dir, spp=None):
    """The Mitsuba 3 scene dictionary of `scene` (plain data, see the module docstring); meshes
    and grids are written into `asset_dir` (created if needed)."""
    asset_dir = Path(asset_dir)
    asset_dir.mkdir(parents=True, exist_ok=True)
    settings = scene.render
    uses_media = scene.medium >= 0 or any(s.interior >= 0 or s.exterior >= 0 for s in scene.shapes)
    integrator = {"type": "volpath" if uses_media else "path", "max_depth": int(settings.max_depth),
                  "rr_depth": int(settings.rr_depth) - (1 if uses_media else 0)}
    out = {"type": "scene", "integrator": integrator,
           "sensor": _sensor(scene, settings.spp if spp is None else spp)}
    for index, medium in enumerate(scene.media):
        out[f"medium_{index}"] = _medium(medium, index, asset_dir)
    camera_medium = scene.camera_medium if scene.camera_medium is not None else scene.medium
    if camera_medium >= 0:
        out["sensor"]["medium"] = {"type": "ref", "id": f"medium_{camera_medium}"}
    for index, shape in enumerate(scene.shapes):
        out[f"shape_{index}"] = _shape(scene, shape, index, asset_dir)
    for index, light in enumerate(scene.lights):
        emitter = _light(light, index)
        if emitter is not None:
            out[f"light_{index}"] = emitter
    return out


def to_mitsuba_dict(description, mi):
    """`description` with every `to_world` matrix made an `mi.ScalarTransform4f` (mi: the
    mitsuba module, variant already set), ready for `mi.load_dict`."""
    if isinstance(description, dict):
        return {key: mi.ScalarTransform4f(value) if key == "to_world" else to_mitsuba_dict(value, mi)
                for key, value in description.items()}
    return description


def _rgb(value):
    return {"type": "rgb", "value": [float(v) for v in value]}


def _sensor(scene, spp):
    import numpy as np

    camera = scene.camera
    width, height = camera.resolution
    forward, right, up = camera.basis()
    # Mitsuba's camera looks down its local +z with +x to the image's left and +y up: columns
    # (-right, up, forward) in the world, at the camera position.
    to_world = np.eye(4)
    to_world[:3, 0] = -right / np.linalg.norm(right)
    to_world[:3, 1] = up / np.linalg.norm(up)
    to_world[:3, 2] = forward
    to_world[:3, 3] = camera.position
    lens = {"type": "thinlens", "aperture_radius": float(camera.aperture_radius),
            "focus_distance": float(camera.focus_distance)} if camera.aperture_radius > 0 else {"type": "perspective"}
    return {**lens, "fov": float(camera.fov), "fov_axis": "y",
            "to_world": to_world.tolist(),
            "film": {"type": "hdrfilm", "width": int(width), "height": int(height),
                     "rfilter": _rfilter(camera.filter), "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": int(spp)}}


def _rfilter(pixel_filter):
    parameter = {"gaussian": {"stddev": pixel_filter.stddev}, "tent": {"radius": pixel_filter.radius}}
    return {"type": pixel_filter.type, **parameter.get(pixel_filter.type, {})}


def _bsdf(material):
    kind = material.type
    if material.textures or material.opacity < 1 or material.bump_map >= 0 or material.normal_map >= 0 \
            or material.back >= 0:
        raise ValueError(f"material {material.name!r} has textures or surface wrappers (opacity, bump, "
                         "normal_map, back), which are not exported")
    if kind in ("diffuse", "emissive"):
        return {"type": "diffuse", "reflectance": _rgb(material.albedo)}
    if kind == "interface":
        return {"type": "null"}
    if kind in _SPECULAR_PLUGINS and material.roughness == 0:
        if kind == "dielectric":
            return {"type": "dielectric", "int_ior": float(material.ior), "ext_ior": float(material.exterior_ior),
                    "specular_transmittance": _rgb(material.tint)}
        return {"type": "conductor", "material": "none", "specular_reflectance": _rgb(material.tint)}
    raise ValueError(f"material {material.name!r} ({kind}"
                     f"{', rough' if kind in _SPECULAR_PLUGINS else ''}) has no exact Mitsuba 3 counterpart")


def _shape(scene, shape, index, asset_dir):
    material = scene.materials[shape.material]
    geometry = shape.mesh
    if hasattr(geometry, "radius"):   # an analytic sphere (meshes.Sphere)
        out = {"type": "sphere", "to_world": _sphere_to_world(geometry), "flip_normals": bool(geometry.flipped)}
    else:
        path = asset_dir / f"shape_{index}.ply"
        write_ply(path, geometry.vertices, geometry.faces, geometry.normals, geometry.uvs)
        out = {"type": "ply", "filename": str(path.resolve()), "face_normals": geometry.normals is None}
    out["bsdf"] = _bsdf(material)
    if any(material.emission > 0):
        out["emitter"] = {"type": "area", "radiance": _rgb(material.emission)}
    for side, medium in (("interior", shape.interior), ("exterior", shape.exterior)):
        if medium >= 0:
            out[side] = {"type": "ref", "id": f"medium_{medium}"}
    return out


def _sphere_to_world(sphere):
    """Mitsuba's to_world of the unit sphere turned (its texture coordinates turn with it),
    scaled and moved onto `sphere`."""
    import numpy as np

    matrix = np.eye(4)
    matrix[:3, :3] = sphere.rotation * sphere.radius
    matrix[:3, 3] = sphere.center
    return matrix.tolist()


def _medium(medium, index, asset_dir):
    import numpy as np

    sigma_t = medium.sigma_a + medium.sigma_s
    albedo = np.divide(medium.sigma_s, sigma_t, out=np.zeros(3), where=sigma_t > 0)
    phase = {"type": "hg", "g": float(medium.g)}
    sampling = {"sample_emitters": bool(medium.sample_emitters)}
    if medium.type == "homogeneous":
        # An "rgb" value would be read as a reflectance (at most 1): unbounded inside a volume.
        extinction = float(sigma_t[0]) if np.all(sigma_t == sigma_t[0]) else {"type": "constvolume",
                                                                                "value": _rgb(sigma_t)}
        return {"type": "homogeneous", "sigma_t": extinction, "albedo": _rgb(albedo), "phase": phase,
                **sampling}
    if not np.all(sigma_t == sigma_t[0]):
        raise ValueError(f"medium {medium.name!r}: a grid medium with chromatic sigma_t has no "
                         "Mitsuba 3 counterpart (its heterogeneous medium scales one density grid)")
    from .grids import write_vol  # noqa: E402 (only the exporting process needs it)

    def grid_volume(values, name):
        path = asset_dir / name
        write_vol(path, values)
        return {"type": "gridvolume", "filename": str(path.resolve()),
                "to_world": np.asarray(medium.grid.to_world, float).tolist()}

    if medium.albedo_grid is not None:   # filling the density's unit cube, as in clrender
        albedo = grid_volume(medium.albedo_grid, f"medium_{index}_albedo.vol")
    else:
        albedo = _rgb(albedo)
    return {"type": "heterogeneous", "id": f"medium_{index}", "albedo": albedo, "scale": float(sigma_t[0]),
            "sigma_t": grid_volume(medium.grid.density, f"medium_{index}.vol"), "phase": phase, **sampling}


def _light(light, index):
    if light.type == "environment":
        if light.image is not None:
            raise ValueError(f"lights[{index}]: image environments are not exported")
        return {"type": "constant", "radiance": _rgb(light.radiance)}
    if light.type == "point":
        return {"type": "point", "position": [float(v) for v in light.position], "intensity": _rgb(light.radiance)}
    if light.type == "spot":
        return {"type": "spot", "to_world": _spot_frame(light), "intensity": _rgb(light.radiance),
                "cutoff_angle": float(light.cutoff_angle), "beam_width": float(light.beam_width)}
    return {"type": "directional", "direction": [float(v) for v in light.direction],
            "irradiance": _rgb(light.radiance)}


def _spot_frame(light):
    """A to_world whose +z is the spot's axis, at its position (rows, as the module's matrices)."""
    import numpy as np

    z = np.asarray(light.direction, float)
    x = np.cross([0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2], frame[:3, 3] = x, np.cross(z, x), z, light.position
    return frame.tolist()


def write_ply(path, vertices, faces, normals=None, uvs=None):
    """A binary little-endian PLY of float32 vertices (and normals, texture coordinates u, v:
    Mitsuba reads them unflipped, as clrender keeps them), int32 triangles."""
    import numpy as np

    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    columns = [vertices]
    if normals is not None:
        fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
        columns.append(normals)
    if uvs is not None:
        fields += [("u", "<f4"), ("v", "<f4")]
        columns.append(uvs)
    vertex = np.zeros(len(vertices), fields)
    for (name, _), values in zip(fields, np.concatenate(columns, axis=1).T):
        vertex[name] = values
    face = np.zeros(len(faces), [("n", "u1"), ("i", "<i4", (3,))])
    face["n"] = 3
    face["i"] = faces
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(vertex)}"]
    header += [f"property float {name}" for name, _ in fields]
    header += [f"element face {len(face)}", "property list uchar int vertex_indices", "end_header", ""]
    Path(path).write_bytes("\n".join(header).encode() + vertex.tobytes() + face.tobytes())
