"""A scene flattened into the arrays the kernel reads (dtypes from layout.py)."""
import sys
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from . import bvh as bvh_module
from . import disk_cache, host_memory, layout, light_selection, limits, meshes, plastic, ploc, principled, textures
from . import wide_bvh
from .triangle_blocks import triangle_blocks, triangle_edges
from .bvh import intersect_brute_force
from .errors import SceneError
from .origins import at_source
from .textures import lets_light_through

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


# Triangles that gathering them and filling their slots handle at a time: the temporaries of
# these steps are then of this size, not of a whole mesh (at 3M triangles they made most of the
# set-up's peak memory; docs/performance.md, "Start-up at scale").
SLOTS_AT_A_TIME = 1 << 16


@dataclass
class SceneArrays:
    nodes: np.ndarray
    blocks: np.ndarray          # the leaves' triangles, eight to a block, their only geometry (triangle_blocks.py)
    spheres: np.ndarray         # layout.SPHERE records of the sphere slots 0 to sphere_count - 1 (one dummy without)
    shading: np.ndarray
    info: np.ndarray
    materials: np.ndarray
    media: np.ndarray
    grid_data: np.ndarray       # float32 voxels of every grid medium, concatenated (one dummy without)
    majorant_data: np.ndarray   # float32 (max, min) per majorant block of every grid, concatenated
    camera_medium: int          # medium index at the camera, -1 for none
    emitters: np.ndarray
    emitter_cdf: np.ndarray
    env_texels: np.ndarray      # (H*W, 4) float32; one dummy texel without an image
    env_cdf: np.ndarray
    env_index: int              # emitter index of the environment, -1 without one
    env_size: tuple             # (width, height) of the environment image, (0, 0) without one
    env_lookup: int             # layout.ENVIRONMENT_LOOKUPS value of the environment image
    env_to_map: np.ndarray      # (3, 3) rotation taking world directions into the image's frame
    first_light: int            # index of the first emitter that is not an area light (lights follow them)
    sphere_count: int           # analytic spheres among the primitive slots, the first ones (the rest: triangles)
    scene_sphere: np.ndarray    # centre xyz, radius
    specular_albedo: np.ndarray  # float32 energy-compensation tables, filled on the device
    table_materials: list       # indices of the materials that own tables (field albedo_tables >= 0)
    bvh_depth: int
    degenerate_triangles: int   # triangles without area in float32 (at the kernel's scale), dropped
    uvs: np.ndarray             # (slots * 3, 2) float32 corner uv of each primitive slot (one dummy
                                # row without textures)
    textures: np.ndarray        # layout.TEXTURE records (one dummy without textures)
    texels: np.ndarray          # uint8 texels of every bitmap (textures.texture_arrays)
    length_scale: float = 1.0   # kernel lengths = scene lengths x this power of two (device_length_scale)
    # The caustic guide (guide.py), filled on the device where it applies: layout.GUIDE_LOBE
    # records (one empty lobe without a guide) and RenderParams' guide_grid, guide_cells, guide_cone.
    guide: np.ndarray = field(default_factory=lambda: np.zeros(1, layout.GUIDE_LOBE))
    guide_grid: tuple = (0.0, 0.0, 0.0, 0.0)
    guide_cells: tuple = (0, 0, 0, 0)
    guide_cone: tuple = (0.0, 0.0, 0.0, 0.0)


def active_environment(scene):
    """The scene's environment light, or None when it has none or it is black."""
    env = scene.environment
    if env is None:
        return None
    if env.image is not None:
        return env if env.image.size and env.image.max() > 0 else None   # (non-negative: a positive texel)
    return env if np.any(env.radiance > 0) else None


# The kernel sees a scene whose extent lies in [2^-SCALE_WINDOW, 2^SCALE_WINDOW].
SCALE_WINDOW = 10


def scene_extent(scene):
    """The largest side of the box around the geometry, the camera, point lights and grid boxes."""
    points = [scene.camera.position[None]]
    points += [np.array(meshes.bounds(s.mesh)) for s in scene.shapes]
    points += [light.position[None] for light in scene.lights if light.position is not None]
    points += [np.array(m.grid.world_bounds()) for m in scene.media if m.grid is not None]
    points = np.concatenate(points)
    return float(np.max(points.max(axis=0) - points.min(axis=0)))


def device_length_scale(scene):
    """The power of two by which the kernel's lengths differ from the scene's: 1 for a scene of
    ordinary size, else the one that brings its extent into [2^-10, 2^10]. The kernel works in
    float32 and squares lengths (normals of triangles square cross products: lengths^4), so a
    scene of 1e12 or 1e-12 units would overflow or underflow. Scaled by a power of two, every
    float32 length scales exactly, and an image does not depend on the scale (radiance is per
    area and solid angle): the render is that of the same scene at an ordinary size."""
    extent = scene_extent(scene)
    if not extent > 0:
        return 1.0
    exponent = int(np.floor(np.log2(extent)))
    shift = min(SCALE_WINDOW - exponent, 0) if exponent > SCALE_WINDOW else max(-SCALE_WINDOW - exponent, 0)
    return 2.0 ** shift


def build_scene_arrays(scene):
    with ThreadPoolExecutor(1, thread_name_prefix="texture-arrays") as worker:
        return _build_scene_arrays(scene, worker)


def _texture_data(scene, with_uv):
    """The texture records and texel buffer (textures.texture_arrays), and every bitmap's mean
    computed (Texture.mean keeps it: plastic's lobe weights and textured emitters ask for it).
    numpy copies and decodes the texels without holding Python's lock: done beside the BVH build."""
    if not with_uv:
        return textures.texture_arrays([])
    for texture in scene.textures:
        if texture.type == "bitmap":
            texture.mean()
    return textures.texture_arrays(scene.textures)


def wide_bvh_of(v0, v1, v2, centres, radii):
    """(wide nodes, depth, primitive order) of the BVH over these triangles and spheres: built
    (ploc.py, wide_bvh.py) once per geometry, then loaded from the disk cache, keyed by the
    primitives and the builders' code (the build was half the set-up of the real interiors).
    The nodes are an aligned, writable array of their own (triangle_blocks changes them)."""
    builders = disk_cache.code_digest(sys.modules[__name__], ploc, bvh_module, wide_bvh, layout)
    entry = disk_cache.key("wide bvh", builders, disk_cache.array_digest(v0, v1, v2, centres, radii))
    cached = disk_cache.load_arrays("bvh", entry)
    if cached is not None:
        # Copies, so that the entry's bytes (which views would keep) are freed now, not after the
        # scene's other arrays have joined them (a large scene's peak memory), and the nodes are
        # writable (triangle_blocks changes them in place) and aligned for reading in place.
        return (host_memory.copy(cached["nodes"].view(layout.WIDE_BVH_NODE)), int(cached["depth"][0]),
                np.array(cached["order"]))
    bvh = ploc.build_ploc_bvh(v0, v1, v2, spheres=(centres, radii))
    order = bvh.prim_order
    # The binary tree goes as soon as it is used: on a large mesh it is hundreds of MB, and the
    # peak memory is that of these steps.
    nodes, depth = wide_bvh.collapse(bvh, order >= len(v0))
    del bvh
    disk_cache.store_arrays("bvh", entry, {"nodes": nodes, "depth": np.array([depth]), "order": order})
    return host_memory.copy(nodes), depth, order


def _build_scene_arrays(scene, worker):
    count = sum(1 if isinstance(shape.mesh, meshes.Sphere) else len(shape.mesh.faces) for shape in scene.shapes)
    if count > limits.MAX_TRIANGLES:   # before the triangles are gathered and the BVH is built
        raise SceneError("shapes", f"{count} primitives, more than the limit of {limits.MAX_TRIANGLES}")
    scale = device_length_scale(scene)
    with_uv = textures.scene_uses_textures(scene)
    texture_data = worker.submit(_texture_data, scene, with_uv)
    v0, v1, v2, normals, info, uvs = _gather_triangles(scene, scale, with_uv)
    keep = _has_float32_area(v0, v1, v2)
    degenerate = int(np.count_nonzero(~keep))
    if degenerate:
        _skip_shapes_without_area(scene, info, keep)
        v0, v1, v2, normals, info, uvs = v0[keep], v1[keep], v2[keep], normals[keep], info[keep], uvs[keep]
    centres, radii, rotations, sphere_info = _gather_spheres(scene, scale)

    nodes, bvh_depth, order = wide_bvh_of(v0, v1, v2, centres, radii)
    order = spheres_first(nodes, order, len(v0))
    unordered_info = np.concatenate([info, sphere_info])
    del info
    camera_medium = scene.camera_medium
    if camera_medium is None:
        camera_medium = _medium_at_camera(scene, scene.camera.position * scale, v0, v1, v2, centres, radii,
                                          unordered_info)
    shading, spheres = primitive_slots(order, normals, centres, radii, rotations)
    del normals   # as soon as the slots hold them: with the blocks below they would add to a large scene's peak memory
    # The slots' TriangleInfo records, written in place (`info`: their int4 fields as rows).
    info_records = host_memory.empty(len(order), layout.TRIANGLE_INFO)
    info = info_records.view(np.int32).reshape(len(order), 4)
    np.take(unordered_info, order, axis=0, out=info, mode="clip")   # "raise" would buffer `out` (order is in range)
    del unordered_info
    try:   # before anything asks for a texture's mean (textured emitters do)
        texture_records, texels = texture_data.result()
    except ValueError as e:
        raise SceneError("textures", str(e)) from None
    emitters, powers, areas = _area_emitters(scene, v0, v1, v2, order, spheres, info)
    nodes, blocks = triangle_blocks(nodes, v0, v1, v2, order)
    del v0, v1, v2

    lo, hi = (corner * scale for corner in scene.bounds())
    sphere = np.append((lo + hi) / 2, max(np.linalg.norm(hi - lo) / 2, 1e-6))
    first_light = len(emitters)
    groups = list(info[emitters["kind"][:, 1], 1])   # the shapes of the area emitters
    env_index, env_size, env_texels, env_cdf = -1, (0, 0), np.zeros((1, 4), np.float32), np.ones(1, np.float32)
    env_lookup, env_to_map = layout.ENVIRONMENT_LOOKUPS["texel"], np.eye(3)
    light_emitters = []
    for index, light in enumerate(scene.lights):
        if light.type == "environment":
            if active_environment(scene) is None:
                continue
            env_index = len(emitters) + len(light_emitters)
            if light.image is not None:
                env_texels, env_cdf, mean = _stored_environment_tables(light.image, light.lookup)
                env_size = (light.image.shape[1], light.image.shape[0])
                env_lookup, env_to_map = layout.ENVIRONMENT_LOOKUPS[light.lookup], light.rotation.T
            else:
                mean = float(light.radiance.mean())
            light_emitters.append(_emitter("environment", light.radiance))
            powers.append(4 * np.pi * np.pi * sphere[3] ** 2 * mean)
        elif light.type in ("point", "spot"):
            # Irradiance intensity / distance^2 must not change with the scale.
            intensity = limits.float32_values(light.radiance * scale**2, f"lights[{index}].intensity", SceneError)
            emitter = _emitter(light.type, intensity, p0=light.position * scale)
            if light.type == "spot":
                emitter["e1"], emitter["e2"] = spot_cone(light)
            light_emitters.append(emitter)
            powers.append(spot_solid_angle(light) * float(intensity.mean()) if light.type == "spot"
                          else 4 * np.pi * float(intensity.mean()))
        else:
            light_emitters.append(_emitter("directional", light.radiance, p0=-light.direction))
            powers.append(np.pi * sphere[3] ** 2 * float(light.radiance.mean()))
    emitters = np.concatenate([emitters] + light_emitters) if light_emitters else emitters
    # Each light a group of its own, after the shapes.
    groups += list(len(scene.shapes) + np.arange(len(light_emitters)))
    selection = light_selection.selection_weights(powers, areas + [1.0] * len(light_emitters), groups, env_index)
    if len(emitters):
        emitters["e2"][:, 3] = light_selection.power_shares(powers)
    materials = _material_array(scene.materials, scene.textures, scale)
    used = set(scene.used_material_indices())
    # Plastic's coat tables are its model, not a compensation.
    compensated = {i for i, m in enumerate(scene.materials) if m.energy_compensation or m.type == "plastic"}
    table_size, table_materials = _assign_albedo_tables(materials, used & compensated)

    media, grid_data, majorant_data = _medium_array(scene.media, scale)
    return SceneArrays(
        nodes=nodes, blocks=blocks, spheres=spheres, shading=shading,
        info=info_records, materials=materials,
        media=media, grid_data=grid_data, majorant_data=majorant_data, camera_medium=camera_medium,
        emitters=emitters, emitter_cdf=_cdf(selection),
        env_texels=env_texels, env_cdf=env_cdf, env_index=env_index, env_size=env_size,
        env_lookup=env_lookup, env_to_map=env_to_map,
        first_light=first_light, sphere_count=len(centres),
        scene_sphere=sphere.astype(np.float32), bvh_depth=bvh_depth,
        degenerate_triangles=degenerate, length_scale=scale,
        specular_albedo=np.zeros(max(table_size, 1), np.float32), table_materials=table_materials,
        uvs=_slot_uvs(order, uvs) if with_uv else np.zeros((1, 2), np.float32),
        textures=texture_records, texels=texels)


def _has_float32_area(v0, v1, v2):
    """Whether each triangle keeps an area in the kernel's float32 arithmetic: its normal
    (cross product of float32 edges) has a normal-range, finite squared length."""
    keep = np.empty(len(v0), bool)
    for first in range(0, len(v0), SLOTS_AT_A_TIME):   # temporaries of a block's size
        at = slice(first, first + SLOTS_AT_A_TIME)
        a = np.asarray(v0[at], np.float32)
        e1 = np.asarray(v1[at], np.float32) - a
        e2 = np.asarray(v2[at], np.float32) - a
        with np.errstate(over="ignore", under="ignore", invalid="ignore"):
            n = np.cross(e1, e2)
            length2 = np.sum(n * n, axis=1, dtype=np.float32)
        keep[at] = np.isfinite(length2) & (length2 >= np.finfo(np.float32).tiny)
    return keep


class SkippedShapeWarning(UserWarning):
    """A shape none of whose triangles has an area (corners collinear or coinciding) is skipped."""


def _skip_shapes_without_area(scene, info, keep):
    """Shapes that lost all their triangles (none in `keep`): one without an area of its own, a
    line or a point as some exporters write them, is skipped with a warning, as Mitsuba loads it
    and never hits it; one that has an area at its own size but none at the scene's scale is a
    mistake (a radius of 1e-30 among metres, a scene too flat), not something to drop silently."""
    total = np.bincount(info[:, 1], minlength=len(scene.shapes))
    kept = np.bincount(info[keep, 1], minlength=len(scene.shapes))
    for index in np.flatnonzero((total > 0) & (kept == 0)):
        shape = scene.shapes[index]
        if not _has_area_of_its_own(shape.mesh):
            where, message = at_source(scene.origins, f"shapes[{index}]",
                                       f"no triangle of {shape.name!r} has an area (their corners are "
                                       "collinear or coincide): skipped, as it cannot be seen")
            warnings.warn(f"{where}: {message}", SkippedShapeWarning, stacklevel=3)
            continue
        sizes = [float(np.max(hi - lo)) for lo, hi in (meshes.bounds(s.mesh) for s in scene.shapes)]
        largest = int(np.argmax(sizes))
        raise SceneError(f"shapes[{index}]", f"all {total[index]} triangles of {shape.name!r} "
                                             f"are degenerate at the scene's scale (no area in float32; "
                                             f"the scene spans {scene_extent(scene):.3g} units, "
                                             f"shapes[{largest}] {scene.shapes[largest].name!r} {sizes[largest]:.3g})")


def _has_area_of_its_own(mesh):
    """Whether a triangle of `mesh` keeps an area in float32 with the mesh moved to the origin
    and scaled to a unit size: false for corners that are collinear or coincide (to float32
    rounding), true for a mesh that is merely tiny or far away."""
    lo, hi = meshes.bounds(mesh)
    size = float(np.max(hi - lo))
    if not size > 0:
        return False
    corners = (mesh.vertices[mesh.faces] - lo) / size
    return bool(np.any(_has_float32_area(corners[:, 0], corners[:, 1], corners[:, 2])))


def spheres_first(nodes, order, n_triangles):
    """The primitive order of a BVH (slot k holds primitive order[k]: triangle i < n_triangles,
    else sphere i - n_triangles) with the spheres' slots first, then the triangles', each in the
    tree's order; the leaves of `nodes` (layout.WIDE_BVH_NODE, before triangle_blocks) are
    renumbered in place to match. The kernel keeps records for the sphere slots only (the
    triangles' geometry is in their blocks), indexed by slot, so those slots come first."""
    order = np.asarray(order)
    is_sphere = order >= n_triangles
    sphere_count = int(np.count_nonzero(is_sphere))
    if sphere_count == 0:
        return order
    renumbered = np.empty(len(order), np.int32)
    renumbered[is_sphere] = np.arange(sphere_count)
    renumbered[~is_sphere] = np.arange(sphere_count, len(order))
    # A leaf's slots are consecutive and all of one kind, so they stay consecutive.
    leaf = nodes["count"] != 0
    nodes["child"][leaf] = renumbered[nodes["child"][leaf]]
    return np.concatenate([order[is_sphere], order[~is_sphere]])


def primitive_slots(order, normals, centres, radii, rotations=None):
    """The kernel's shading buffer over the primitive slots of a BVH (slot k holds primitive
    order[k]: triangle i < len(normals), else sphere i - len(normals); the spheres' slots first,
    spheres_first) and the sphere records of those first slots (layout.SPHERE; one dummy without
    spheres): centre and signed radius, the x and z axes of the object frame (`rotations`,
    (S, 3, 3); identity if None), z_axis.w -1 where that frame is mirrored (kernels/scene.h,
    sphere_uv). A sphere slot has no shading normals."""
    order = np.asarray(order)
    n_triangles = len(normals)
    sphere_count = len(order) - int(np.count_nonzero(order < n_triangles))
    if np.any(order[:sphere_count] < n_triangles):
        raise ValueError("the spheres' slots must come first (spheres_first)")
    shading = host_memory.zeros(len(order), layout.TRIANGLE_SHADING)
    packed_normals = shading["normals"]
    corner_normals = np.asarray(normals, np.float32).reshape(-1, 9)
    # In blocks: the gathered normals are temporaries of a block's size (SLOTS_AT_A_TIME).
    for start in range(sphere_count, len(order), SLOTS_AT_A_TIME):
        slots = slice(start, min(start + SLOTS_AT_A_TIME, len(order)))
        corners = np.take(corner_normals, order[slots], axis=0).reshape(-1, 3, 3)
        packed_normals[slots, :3] = layout.pack_normals(corners)
        packed_normals[slots, 3] = np.any(corners != 0, axis=(1, 2))   # smooth; else flat
    spheres = np.zeros(max(sphere_count, 1), layout.SPHERE)
    if sphere_count:
        index = order[:sphere_count] - n_triangles
        spheres["centre_radius"][:sphere_count, :3] = np.asarray(centres).reshape(-1, 3)[index]
        spheres["centre_radius"][:sphere_count, 3] = np.asarray(radii)[index]
        frames = np.tile(np.eye(3), (len(index), 1, 1)) if rotations is None else np.asarray(rotations)[index]
        spheres["x_axis"][:sphere_count, :3] = frames[:, :, 0]
        spheres["z_axis"][:sphere_count, :3] = frames[:, :, 2]
        spheres["z_axis"][:sphere_count, 3] = np.sign(np.linalg.det(frames))
    return shading, spheres


def _slot_uvs(order, uvs):
    """The (slots * 3, 2) corner uv of each primitive slot (a sphere's computed in the kernel)."""
    order = np.asarray(order)
    out = host_memory.zeros((len(order), 3, 2), np.float32)
    triangle = order < len(uvs)
    # Without spheres every slot is a triangle's: a slice, as in primitive_slots.
    slots = slice(None) if triangle.all() else np.flatnonzero(triangle)
    out[slots] = np.take(uvs, order[slots], axis=0)
    return out.reshape(-1, 2)


def _gather_spheres(scene, scale=1.0):
    """The analytic spheres of all shapes: centres (S, 3) and signed radii (S,) (negative when
    flipped), times `scale`, their object-to-world rotations (S, 3, 3) and their TriangleInfo
    columns (S, 4)."""
    found = [(index, shape) for index, shape in enumerate(scene.shapes) if isinstance(shape.mesh, meshes.Sphere)]
    centres = np.array([shape.mesh.center for _, shape in found], float).reshape(-1, 3) * scale
    radii = np.array([-shape.mesh.radius if shape.mesh.flipped else shape.mesh.radius for _, shape in found], float) * scale
    for (index, shape), radius in zip(found, radii):
        # The kernel squares radii: a sphere tiny against the scene would have none in float32.
        if not abs(radius) ** 2 >= np.finfo(np.float32).tiny:
            raise SceneError(f"shapes[{index}]", f"sphere {shape.name!r} of radius {shape.mesh.radius:.3g} is "
                                                 f"degenerate at the scene's scale (the scene spans "
                                                 f"{scene_extent(scene):.3g} units)")
    info = np.array([[shape.material, index, -1, layout.pack_media(shape.interior, shape.exterior)]
                     for index, shape in found], np.int32).reshape(-1, 4)
    rotations = np.array([shape.mesh.rotation for _, shape in found], float).reshape(-1, 3, 3)
    return centres, radii, rotations, info


# The corner uv of a triangle of a mesh without texture coordinates: uv = (b1, b2), Mitsuba's.
BARYCENTRIC_UV = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])


def _gather_triangles(scene, scale=1.0, with_uv=False):
    """Concatenate all meshes: float32 corners (times `scale`; the kernel's, as the BVH bounds
    them), float32 per-corner normals (F, 3, 3; zero for flat meshes), the TriangleInfo columns
    (material, object, emitter = -1, packed media) and, `with_uv`, the float32 corner uv per
    triangle ((F, 3, 2); else (F, 0, 2)). Written into arrays of the final size, mesh after mesh,
    so that a large mesh passes through no float64 or concatenated copies."""
    found = [(index, shape.mesh) for index, shape in enumerate(scene.shapes)
             if not isinstance(shape.mesh, meshes.Sphere)]
    total = sum(len(mesh.faces) for _, mesh in found)
    v0, v1, v2 = (np.empty((total, 3), np.float32) for _ in range(3))
    normals = np.empty((total, 3, 3), np.float32)
    info = np.empty((total, 4), np.int32)
    uvs = np.empty((total, 3 if with_uv else 0, 2), np.float32)
    end = 0
    for object_id, mesh in found:
        shape = scene.shapes[object_id]
        info[end:end + len(mesh.faces)] = [shape.material, object_id, -1,
                                           layout.pack_media(shape.interior, shape.exterior)]
        scaled = (mesh.vertices * scale).astype(np.float32)
        mesh_normals = None if mesh.normals is None else np.asarray(mesh.normals, np.float32)
        mesh_uvs = None if mesh.uvs is None or not with_uv else np.asarray(mesh.uvs, np.float32)
        # In blocks (SLOTS_AT_A_TIME): no float64 corners of every face (72 bytes a triangle).
        for first in range(0, len(mesh.faces), SLOTS_AT_A_TIME):
            faces = mesh.faces[first:first + SLOTS_AT_A_TIME]
            at = slice(end + first, end + first + len(faces))
            for k, corner in enumerate((v0, v1, v2)):
                np.take(scaled, faces[:, k], axis=0, out=corner[at])
            if mesh_normals is not None:
                np.take(mesh_normals, faces, axis=0, out=normals[at])
            else:
                normals[at] = 0.0   # flat: the kernel shades with the geometric normal
            if with_uv:
                if mesh_uvs is None:
                    uvs[at] = BARYCENTRIC_UV
                else:
                    np.take(mesh_uvs, faces, axis=0, out=uvs[at])
        end += len(mesh.faces)
    return v0, v1, v2, normals, info, uvs


def _area_emitters(scene, v0, v1, v2, order, spheres, info):
    """One emitter per primitive slot whose material emits, triangles first, then spheres;
    records its index in info[:, 2]. Slot k holds primitive order[k] (triangle i of the corners
    v0, v1, v2, or a sphere of `spheres` in the first slots: spheres_first). Returns the
    emitters, their powers (pi x area x mean radiance, as one-sided Lambertian emitters) and
    areas (clrender/light_selection.py). A textured emission counts with its texture's mean,
    and the emitter names the texture and its slot."""
    emission = np.array([m.emission for m in scene.materials]).reshape(-1, 3)
    mean_emission = emission.copy()
    reference = np.full(len(scene.materials), layout.TEXTURE_REF_NONE)
    for index, material in enumerate(scene.materials):
        if "emission" in material.textures:
            texture = material.textures["emission"]
            mean_emission[index] = scene.textures[texture].mean()
            reference[index] = layout.texture_reference(texture, scalar=False)
    emits = np.any(mean_emission > 0, axis=1)[info[:, 0]] if len(info) else np.zeros(0, bool)
    is_sphere = np.asarray(order) >= len(v0)
    triangle_slots, sphere_slots = np.flatnonzero(emits & ~is_sphere), np.flatnonzero(emits & is_sphere)
    slots = np.concatenate([triangle_slots, sphere_slots])
    info[slots, 2] = np.arange(len(slots))
    emitters = np.zeros(len(slots), layout.EMITTER)
    emitters["radiance"][:, :3] = emission[info[slots, 0]]
    emitters["radiance"][:, 3] = reference[info[slots, 0]]
    emitters["kind"][:, 1] = slots
    emitters["kind"][:, 0] = np.where(is_sphere[slots], layout.EMITTER_KINDS["sphere"], layout.EMITTER_KINDS["triangle"])
    triangles = len(triangle_slots)
    p0, e1, e2 = triangle_edges(v0, v1, v2, np.asarray(order)[triangle_slots])
    triangle_area = 0.5 * np.linalg.norm(np.cross(e1.astype(float), e2.astype(float)), axis=1)
    emitters["p0"][:triangles, :3] = p0
    emitters["p0"][:triangles, 3] = triangle_area
    emitters["e1"][:triangles, :3] = e1
    emitters["e2"][:triangles, :3] = e2
    emitters["p0"][triangles:] = spheres["centre_radius"][sphere_slots]   # centre and signed radius
    area = np.concatenate([triangle_area, 4 * np.pi * spheres["centre_radius"][sphere_slots, 3].astype(float) ** 2])
    return emitters, list(np.pi * area * mean_emission[info[slots, 0]].mean(axis=1)), list(area)


def spot_cone(light):
    """The Emitter's e1 and e2 of a spot light (kernels/types.h): its axis and the cosines and
    angles of its falloff (a beam wider than the cutoff is the cutoff, as in Mitsuba)."""
    cutoff = np.radians(light.cutoff_angle)
    beam = np.radians(min(light.beam_width, light.cutoff_angle))
    transition = 1.0 / (cutoff - beam) if beam < cutoff else 0.0
    return [*light.direction, np.cos(cutoff)], [np.cos(beam), cutoff, transition, 0.0]


def spot_solid_angle(light):
    """The integral of a spot light's falloff over the sphere (its power over its intensity):
    2 pi times the integral of falloff(theta) sin(theta), 1 up to the beam, then linear in theta to
    0 at the cutoff."""
    cutoff = np.radians(light.cutoff_angle)
    beam = np.radians(min(light.beam_width, light.cutoff_angle))
    if beam >= cutoff:
        return 2 * np.pi * (1 - np.cos(cutoff))
    return 2 * np.pi * (1 + (np.sin(beam) - np.sin(cutoff)) / (cutoff - beam))


def _emitter(kind, radiance, p0=(0, 0, 0)):
    e = np.zeros(1, layout.EMITTER)
    e["kind"][:, 0] = layout.EMITTER_KINDS[kind]
    e["radiance"][:, :3] = radiance
    e["p0"][:, :3] = p0
    return e


def _material_array(materials, textures=(), length_scale=1.0):
    """The Material records; textures: the scene's (plastic's sampling weight reads their means);
    length_scale: the device's (device_length_scale), by which a bump map's heights scale as the
    surface's derivatives do."""
    out = np.zeros(len(materials), layout.MATERIAL)
    layout.clear_texture_references(out)
    for i, m in enumerate(materials):
        kind = m.type if m.type in layout.MATERIAL_KINDS else "diffuse"  # emissive: black diffuse
        if m.index_matched:
            kind = "interface"
        record = out[i]
        _set(record, "kind", layout.MATERIAL_KINDS[kind])
        _set(record, "one_sided", int(not m.two_sided))
        _set(record, "back_material", m.back)
        _set(record, "normal_map", m.normal_map)
        _set(record, "bump_map", m.bump_map)
        _set(record, "bump_scale", m.bump_scale * length_scale)
        _set(record, "opacity", m.opacity)
        _set(record, "masked", int(any(lets_light_through(materials[j]) for j in (i, m.back) if j >= 0)))
        _set(record, "emission", m.emission)
        if kind == "interface":   # the transmittance of the boundary
            _set(record, "color", m.tint if m.index_matched else 1.0)
        elif kind == "plastic":
            plastic.set_fields(record, m, textures)
        elif kind in ("dielectric", "conductor", "thin_dielectric"):
            _set(record, "color", m.tint)
            _set(record, "ior", m.ior)
            _set(record, "exterior_ior", m.exterior_ior)
            _set(record, "reflection_tint", m.reflection_tint)
            _set(record, "conductor_eta", m.conductor_eta)
            _set(record, "conductor_k", m.conductor_k)
            # Squared in float32, as the kernel would: alpha = roughness^2.
            _set(record, "alpha", np.float32(m.roughness) * np.float32(m.roughness))
            _set(record, "distribution", layout.MICROFACET_DISTRIBUTIONS[m.distribution])
            _set(record, "masking", layout.MASKINGS[m.masking])
        else:
            _set(record, "color", m.albedo)
        if m.toon is not None:
            _toon_fields(record, m.toon)
        if m.principled is not None:
            principled.write_fields(record, m.principled)
        for name, texture in m.textures.items():
            layout.set_texture_reference(record, name, texture)
    return out


def _set(material, name, value):
    layout.set_field(material, layout.MATERIAL_FIELDS, name, value)


def _get(material, name):
    return layout.field(material, layout.MATERIAL_FIELDS, name)


def needs_albedo_table(material):
    """Whether a Material record is a rough specular lobe, compensated by tables, or a plastic with
    a rough coat (clrender/plastic.py); mirrors material_is_delta in kernels/materials/bsdf.h
    (float32 alpha against MICROFACET_MIN_ALPHA)."""
    kind = int(_get(material, "kind"))
    if kind == layout.MATERIAL_KINDS["plastic"]:
        return plastic.table_rows(material) > 0
    if kind not in (layout.MATERIAL_KINDS["dielectric"], layout.MATERIAL_KINDS["conductor"]):
        return False
    return bool(_get(material, "alpha") >= np.float32(1e-3))


def _assign_albedo_tables(materials, used):
    """Give each rough specular material in `used` (those that a shape uses, with energy
    compensation on) its table slots (field albedo_tables; a dielectric needs two: wo outside and
    wo inside); returns the total size and the owners. Others get none: the kernel of a scene
    without specular shapes has no table code."""
    size, owners = 0, []
    for i in range(len(materials)):
        _set(materials[i], "albedo_tables", -1)
        if i in used and needs_albedo_table(materials[i]):
            _set(materials[i], "albedo_tables", size)
            size += _table_floats(materials[i])
            owners.append(i)
    return size, owners


def _table_floats(material):
    """The floats of Scene.specular_albedo a material's tables take: a dielectric has two sides
    (wo outside and inside)."""
    kind = _get(material, "kind")
    if kind == layout.MATERIAL_KINDS["plastic"]:
        return plastic.table_floats(material)
    return (2 if kind == layout.MATERIAL_KINDS["dielectric"] else 1) * layout.ALBEDO_TABLE_SIZE


def _medium_array(media, scale=1.0):
    """Medium records, and the voxel and majorant buffers that grid media index into;
    coefficients per unit of kernel length (`scale` kernel units per scene unit)."""
    out = np.zeros(max(len(media), 1), layout.MEDIUM)
    voxels, majorants = [], []
    voxel_count = cell_count = 0
    for i, medium in enumerate(media):
        record = out[i]
        put = lambda name, value: layout.set_field(record, layout.MEDIUM_FIELDS, name, value)  # noqa: E731
        put("sigma_a", limits.float32_values(medium.sigma_a / scale, f"media[{i}]", SceneError))
        put("sigma_s", limits.float32_values(medium.sigma_s / scale, f"media[{i}]", SceneError))
        put("g", medium.g)
        put("sample_emitters", float(medium.sample_emitters))
        put("kind", layout.MEDIUM_KINDS[medium.type])
        if medium.grid is None:
            continue
        grid = medium.grid
        high, low = grid.majorants()
        put("voxel_offset", voxel_count)
        put("majorant_offset", cell_count)
        put("majorant_block", grid.block)
        put("resolution", grid.resolution)
        put("majorant_resolution", high.shape[::-1])
        record["to_voxel"] = grid.world_to_voxel() * [1 / scale, 1 / scale, 1 / scale, 1]
        voxels.append(grid.density.ravel())
        majorants.append(np.stack([high.ravel(), low.ravel()], axis=1).ravel())
        voxel_count += grid.density.size
        cell_count += high.size
        if medium.albedo_grid is not None:
            nz, ny, nx, channels = medium.albedo_grid.shape
            put("albedo_offset", voxel_count)
            put("albedo_channels", channels)
            put("albedo_resolution", (nx, ny, nz))
            voxels.append(medium.albedo_grid.ravel())
            voxel_count += medium.albedo_grid.size
    if voxel_count + cell_count * 2 >= 2**31:
        raise SceneError("media", "grid media too large: more than 2^31 floats in all")
    grid_data = np.concatenate(voxels).astype(np.float32) if voxels else np.zeros(1, np.float32)
    majorant_data = np.concatenate(majorants).astype(np.float32) if majorants else np.zeros(2, np.float32)
    return out, grid_data, majorant_data


def _medium_at_camera(scene, position, v0, v1, v2, centres, radii, info):
    """The medium around the camera: the first surface along the view direction tells whether
    the camera is behind its front face (inside the interior medium) or in front of it.
    info: the TriangleInfo rows of the triangles, then of the spheres."""
    if len(info) == 0 or not scene.media:   # without media every surface has -1 on both sides
        return scene.medium
    direction = scene.camera.look_at - position
    direction = direction / np.linalg.norm(direction)
    t, hit = intersect_brute_force(v0, v1, v2, position[None], direction[None], spheres=(centres, radii))
    if hit[0] < 0:
        return scene.medium
    if hit[0] >= len(v0):   # a sphere: the front normal is outwards, inwards when flipped
        k = hit[0] - len(v0)
        normal = (position + t[0] * direction - centres[k]) * np.sign(radii[k])
    else:
        normal = np.cross(v1[hit[0]] - v0[hit[0]], v2[hit[0]] - v0[hit[0]])
    packed = int(info[hit[0], 3])
    interior, exterior = (packed & 0xFFFF) - 1, (packed >> 16) - 1
    return interior if np.dot(normal, direction) > 0 else exterior


def moved_camera_medium(scene, scale):
    """SceneArrays.camera_medium for `scene`'s camera after it moved (Renderer.set_camera): the
    scene's camera_medium if set, else found as build_scene_arrays finds it, from the shapes
    gathered again at the arrays' length `scale`."""
    if scene.camera_medium is not None:
        return scene.camera_medium
    v0, v1, v2, _, info, _ = _gather_triangles(scene, scale)
    keep = _has_float32_area(v0, v1, v2)
    centres, radii, _, sphere_info = _gather_spheres(scene, scale)
    return _medium_at_camera(scene, scene.camera.position * scale, v0[keep], v1[keep], v2[keep], centres, radii,
                             np.concatenate([info[keep], sphere_info]))


def _toon_fields(record, toon):
    """The toon_* fields of one Material record (meaning in layout.MATERIAL_FIELDS)."""
    for name, value in (("toon_shadow_color", toon.shadow_color), ("toon_shadow_factor", toon.shadow_factor),
                        ("toon_bands", toon.bands), ("toon_band_softness", toon.softness),
                        ("toon_highlight_size", toon.highlight_size),
                        ("toon_highlight_softness", toon.highlight_softness),
                        ("toon_highlight_color", toon.highlight_color), ("toon_rim_width", toon.rim_width),
                        ("toon_rim_color", toon.rim_color), ("toon_rim_threshold", toon.rim_threshold),
                        ("toon_ambient", toon.ambient)):
        _set(record, name, value)


def _cdf(weights):
    """Normalised CDF with len(weights) + 1 entries, ending exactly at 1 (uniform if all zero)."""
    if len(weights) == 0:
        return np.array([0.0, 1.0], np.float32)
    if not weights.sum() > 0:
        weights = np.ones_like(weights)
    cdf = np.concatenate([[0.0], np.cumsum(weights) / weights.sum()])
    cdf[-1] = 1.0
    return cdf.astype(np.float32)


# The environment's sampling grid has at most this many columns: cells of 2 x 2, 4 x 4, ...
# texels of a finer map. The tables then stay in the caches (a 4096 x 2048 map's own would be
# 32 MiB, and its texel rows 16 KiB to search), which paid 1.5-2x in the renders of maps that the
# Mitsuba reader resampled to 4096 across (docs/performance.md, issue 24).
ENV_SAMPLING_COLUMNS = 1024



def environment_sampling_grid(width, height):
    """(columns, rows) of the sampling grid over width x height cells: columns halved while more
    than ENV_SAMPLING_COLUMNS and even, the rows with them while even (Mitsuba's lookup has an odd
    number of cells down a map of even height)."""
    columns, rows = width, height
    while columns > ENV_SAMPLING_COLUMNS and columns % 2 == 0:
        columns //= 2
        rows = rows // 2 if rows % 2 == 0 else rows
    return columns, rows


def environment_cells(image, lookup):
    """(rows, columns) of the cells of the (u, v) square (kernels/lights.h) over which an
    environment image's radiance is one texel (lookup "texel") or the bilinear blend of the four
    texels at its corners ("mitsuba": a cell between each two columns, the last and the first
    included, and each two rows)."""
    height, width, _ = image.shape
    return (height, width) if lookup == "texel" else (height - 1, width)


def _cell_values(image, first, count, lookup):
    """Per cell of the rows first .. first + count: luminance (non-negative) and the mean of the
    channels, each the cell's mean over (u, v) (a bilinear patch's is that of its corners)."""
    if lookup == "texel":
        texels = image[first:first + count]
        return np.maximum(texels @ LUMINANCE, 0), texels.mean(axis=2, dtype=np.float64)
    texels = image[first:first + count + 1]
    values = []
    for value in (np.maximum(texels @ LUMINANCE, 0), texels.mean(axis=2, dtype=np.float64)):
        across = value + np.roll(value, -1, axis=1)
        values.append((across[:-1] + across[1:]) / 4)
    return values


def _stored_environment_tables(image, lookup):
    """_environment_tables, its CDFs and mean computed once per image and kept on disk (the
    living room's 2048 x 1024 map took 0.2 s of its start-up to tabulate, 0.02 s to hash)."""
    entry = disk_cache.key("environment tables", disk_cache.code_digest(sys.modules[__name__], layout), lookup,
                           ENV_SAMPLING_COLUMNS, layout.ENV_CDF_BLOCK, disk_cache.array_digest(image))
    stored = disk_cache.load_arrays("environment", entry)
    if stored is not None:
        return _environment_texels(image), stored["cdf"], float(stored["mean"][0])
    texels, cdf, mean = _environment_tables(image, lookup)
    disk_cache.store_arrays("environment", entry, {"cdf": cdf, "mean": np.array([mean])})
    return texels, cdf, mean


def _environment_texels(image):
    """The kernel's texels of an environment image: RGB and a fourth float (float4 loads), on a
    page boundary (host_memory: a CPU device reads them in place, no second copy of the map)."""
    texels = host_memory.zeros((image.shape[0] * image.shape[1], 4), np.float32)
    texels[:, :3] = image.reshape(-1, 3)
    return texels


def _environment_tables(image, lookup="texel"):
    """Texels and the sampling CDFs of a lat-long image: the luminance x sin(theta) of each cell
    of the (u, v) square (environment_cells) summed over each cell of its sampling grid
    (environment_sampling_grid), uniform in (u, v) within a grid cell.

    Returns (texels, [grid columns, grid rows, marginal | conditional rows | every
    layout.ENV_CDF_BLOCK-th entry of the marginal | of each row], mean radiance over the sphere).
    Computed a band of rows at a time, in float64, stored in float32: a large map needs no
    full-size float64 temporaries."""
    height, width = environment_cells(image, lookup)
    columns, rows_count = environment_sampling_grid(width, height)
    fx, fy = width // columns, height // rows_count
    sin_theta = np.sin((np.arange(height) + 0.5) / height * np.pi)
    cdf = np.empty(2 + rows_count + 1 + rows_count * (columns + 1), np.float32)
    cdf[:2] = columns, rows_count
    rows = cdf[2 + rows_count + 1:].reshape(rows_count, columns + 1)
    row_sums = np.empty(rows_count)
    mean = 0.0
    band = max(1, (1 << 20) // (width * fy))   # grid rows per band
    for first in range(0, rows_count, band):
        part = slice(first, first + band)
        cell_rows = slice(first * fy, (first + band) * fy)
        luminance, grey = _cell_values(image, cell_rows.start, band * fy, lookup)
        mean += float(grey.sum(axis=1) @ sin_theta[cell_rows])
        weights = luminance * sin_theta[cell_rows, None]
        weights = weights.reshape(-1, fy, columns, fx).sum(axis=(1, 3))
        row_sums[part] = weights.sum(axis=1)
        weights[~(row_sums[part] > 0)] = 1.0   # a black row: uniform (it is never chosen)
        rows[part, 0] = 0.0
        rows[part, 1:] = np.cumsum(weights, axis=1) / weights.sum(axis=1, keepdims=True)
        rows[part, -1] = 1.0
    cdf[2:2 + rows_count + 1] = _cdf(row_sums)
    block_starts = [cdf[2:2 + rows_count:layout.ENV_CDF_BLOCK], rows[:, :columns:layout.ENV_CDF_BLOCK].ravel()]
    return _environment_texels(image), np.concatenate([cdf, *block_starts]), mean / (sin_theta.sum() * width)
