"""The caustic guide: where light from a directional light crosses glossy glass or metal and then
lands on a diffuse surface, that surface receives it from a few narrow cones of directions (the
sun refracted by each face of a glass block, and again after each reflection inside it), which
cosine sampling finds only by chance: rare, bright samples. Before rendering, photons
(kernels/guide_photons.cl) follow the light through specular and glossy surfaces to the first
diffuse one; their arrival directions, binned per cell of a grid over where they landed, become
up to layout.GUIDE_LOBES cones per cell, weighted by the light they carry (the lobes of
kernels/guide.h). Diffuse sampling then draws SHARE of its directions from the cones of its
cell and weighs every sample by the mixture's density (materials/diffuse.h): the guide changes
only the noise, never the image's expectation. A fixed number of photons with a fixed seed,
sorted by index, so the guide (and the image) is the same however the render is split.
"""
import math

import numpy as np

from . import layout

PHOTONS = 1 << 16
SEED = 0x67756964
SHARE = 0.25                 # of diffuse samples drawn from the guide where a cell has lobes
CONE_HALF_ANGLE = 0.08      # radians (0.04-0.15 measured alike on ppg-torus: docs/performance.md)
CELLS_ALONG_LONGEST = 32    # cells along the longest side of the box the photons landed in
DIRECTION_BINS = 64         # octahedral bins per side for grouping arrival directions
RECORD_FLOATS = 8           # (point, luminance), (arrival direction, photon index bits)


def applies(scene, features):
    """Whether the scene gets a guide: path tracing, render.caustic_guide on, no media or toon
    shading (the photons know neither), a directional light, a diffuse material and a glossy
    (rough) dielectric or conductor, through which a path tracer's light samples at the glossy
    surface carry that light as rare, bright samples. (A smooth one passes none of a directional
    light to a path tracer at all, and the light paths take area lights' caustics: light_paths.py.)"""
    settings = scene.render
    if not settings.caustic_guide or settings.integrator != "path":
        return False
    if features["MEDIA"] or features["TOON"] or features["GRID_MEDIA"]:
        return False
    if not any(light.type == "directional" and np.any(light.radiance > 0) for light in scene.lights):
        return False
    materials = [scene.materials[shape.material] for shape in scene.shapes]
    return any(m.type == "diffuse" for m in materials) and any(_glossy(m) for m in materials)


def _glossy(material):
    """A rough dielectric or conductor (features.py's smoothness test, not index-matched)."""
    if material.type not in ("dielectric", "conductor") or material.index_matched:
        return False
    return bool(np.float32(material.roughness) ** 2 >= np.float32(1e-3)) or "alpha" in material.textures


def specular_sphere(scene, length_scale):
    """(centre xyz, radius) in kernel lengths bounding the shapes of specular and glossy
    materials: where a directional light's photons are aimed."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for shape in scene.shapes:
        if scene.materials[shape.material].type not in ("dielectric", "conductor", "thin_dielectric"):
            continue
        mesh = shape.mesh
        if hasattr(mesh, "radius"):
            lo = np.minimum(lo, mesh.center - mesh.radius)
            hi = np.maximum(hi, mesh.center + mesh.radius)
        elif len(mesh.faces):
            used = mesh.vertices[np.unique(mesh.faces)]
            lo = np.minimum(lo, used.min(axis=0))
            hi = np.maximum(hi, used.max(axis=0))
    if not np.all(hi >= lo):
        return np.zeros(4, np.float32)
    centre = (lo + hi) / 2
    return np.array([*(centre * length_scale), np.linalg.norm(hi - lo) / 2 * length_scale], np.float32)


def octahedral_bins(directions, bins):
    """Each unit direction's bin of an octahedral map of bins x bins cells (about equal solid
    angles), as one integer."""
    d = directions / np.abs(directions).sum(axis=1, keepdims=True)
    x, y = d[:, 0], d[:, 1]
    lower = d[:, 2] < 0
    fx = np.where(lower, (1 - np.abs(y)) * np.sign(x + (x == 0)), x)
    fy = np.where(lower, (1 - np.abs(x)) * np.sign(y + (y == 0)), y)
    ix = np.clip(((fx + 1) / 2 * bins).astype(np.int64), 0, bins - 1)
    iy = np.clip(((fy + 1) / 2 * bins).astype(np.int64), 0, bins - 1)
    return iy * bins + ix


def build(records):
    """(lobes, guide_grid, guide_cells, guide_cone) from the photons' records ((n, RECORD_FLOATS)
    float32, any order): None where no photon landed. Per cell, the photons' arrival directions
    are binned (octahedral, DIRECTION_BINS per side); the GUIDE_LOBES bins holding most of the
    light become its cones, each along its photons' light-weighted mean direction, with its
    share of their light as the lobe's weight (cumulative, the last exactly 1)."""
    records = np.asarray(records, np.float32).reshape(-1, RECORD_FLOATS)
    keep = np.all(np.isfinite(records[:, :7]), axis=1) & (records[:, 3] > 0)
    records = records[keep]
    if not len(records):
        return None
    records = records[np.argsort(records[:, 7].view(np.int32), kind="stable")]   # the order of the photons
    points = records[:, :3].astype(np.float64)
    power = records[:, 3].astype(np.float64)
    directions = records[:, 4:7].astype(np.float64)
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    lo, hi = points.min(axis=0), points.max(axis=0)
    edge = max(float((hi - lo).max()), 1e-6) / CELLS_ALONG_LONGEST
    lo = lo - edge / 2   # half a cell of margin: the points on the box's faces fall inside
    cells = np.maximum(np.ceil((hi + edge / 2 - lo) / edge).astype(np.int64), 1)
    index = np.minimum(((points - lo) / edge).astype(np.int64), cells - 1)
    cell = (index[:, 2] * cells[1] + index[:, 1]) * cells[0] + index[:, 0]
    key = cell * DIRECTION_BINS**2 + octahedral_bins(directions, DIRECTION_BINS)
    keys, group = np.unique(key, return_inverse=True)
    light = np.bincount(group, weights=power)
    mean = np.stack([np.bincount(group, weights=power * directions[:, k]) for k in range(3)], axis=1)
    group_cell = keys // DIRECTION_BINS**2
    # Per cell, its groups by light, the most first (ties: the lower key), the first GUIDE_LOBES kept.
    order = np.lexsort((keys, -light, group_cell))
    group_cell, light, mean = group_cell[order], light[order], mean[order]
    starts = np.searchsorted(group_cell, group_cell, side="left")
    rank = np.arange(len(group_cell)) - starts
    kept = rank < layout.GUIDE_LOBES
    group_cell, light, mean, rank = group_cell[kept], light[kept], mean[kept], rank[kept]
    cell_count = int(np.prod(cells))
    total = np.bincount(group_cell, weights=light, minlength=cell_count)
    running = np.cumsum(light)
    first = np.searchsorted(group_cell, group_cell, side="left")
    cumulative = (running - np.where(first > 0, running[first - 1], 0.0)) / total[group_cell]
    lobes = np.zeros(cell_count * layout.GUIDE_LOBES, layout.GUIDE_LOBE)
    slot = group_cell * layout.GUIDE_LOBES + rank
    lobes["direction"][slot, :3] = mean / np.linalg.norm(mean, axis=1, keepdims=True)
    lobes["direction"][slot, 3] = cumulative
    # A cell's weights close at exactly 1, and its unused lobes repeat that (with no weight of
    # their own), so every u in [0, 1) finds a lobe.
    used = np.bincount(group_cell, minlength=cell_count)[:, None]
    closing = (np.arange(layout.GUIDE_LOBES)[None, :] >= used - 1) & (used > 0)
    lobes["direction"][closing.ravel(), 3] = 1.0
    cos_cone = math.cos(CONE_HALF_ANGLE)
    solid_angle = 2 * math.pi * (1 - cos_cone)
    grid = (*lo.astype(np.float32), np.float32(1 / edge))
    return lobes, grid, (*cells.astype(int), 1), (SHARE, cos_cone, 1 / solid_angle, 0.0)
