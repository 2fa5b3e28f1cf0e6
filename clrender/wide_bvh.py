"""The eight-wide BVH the kernel traverses, collapsed from the binary SAH tree (bvh.py).

Each wide node holds up to eight children's boxes in structure-of-arrays form (one child per
float8 lane), so the kernel tests all eight with a handful of vector instructions. A wide node
starts from a binary node's two children and fills its lanes greedily: while a lane is free, the
interior child of largest surface area (the one rays enter most often) is replaced by its own
two children (as Embree and pbrt collapse binary trees). Before that, a subtree of at most
MAX_LEAF triangles (or MAX_SPHERE_LEAF spheres) in contiguous slots becomes one leaf (the kernel
tests a leaf's triangles eight at once, so fewer, fuller leaves cost fewer node visits for no more
triangle tests), unless its box is much larger than its parts' (MERGED_AREA_LIMIT). Done level by
level with numpy (a million triangles in well under a second).
"""
import numpy as np

from . import layout


def collapse(bvh, sphere_slots=None):
    """(nodes, depth): the wide tree (dtype layout.WIDE_BVH_NODE; node 0 the root) of a binary
    Bvh. Leaves keep their primitive ranges (the same reordered primitive slots); a leaf of
    spheres (sphere_slots: bool per slot, True for a sphere) gets its count negated, the
    kernel's primitive-type tag (build_bvh never mixes the two in a leaf)."""
    lo, hi, index, count = _binary_slots(bvh.nodes)
    area = _slot_areas(lo, hi)
    index, count = _merge_small_subtrees(index, count, area, sphere_slots)
    interior = (count == 0) & (index >= 0)
    wide_of = np.full(len(bvh.nodes), -1, np.int64)  # binary node -> wide node
    levels, frontier, numbered = [], np.array([0]), 0
    while frontier.size:  # breadth first: a level's wide nodes are numbered together
        wide_of[frontier] = np.arange(numbered, numbered + frontier.size)
        numbered += frontier.size
        node, side = _greedy_slots(frontier, area, index, interior)
        levels.append((node, side))
        below = (node >= 0) & interior[np.maximum(node, 0), side]
        frontier = index[node[below], side[below]]
    slot_node, slot_side = (np.concatenate(lanes) for lanes in zip(*levels))
    nodes = _assemble(slot_node, slot_side, wide_of, lo, hi, index, count)
    if sphere_slots is not None and np.any(sphere_slots):
        leaf = nodes["count"] > 0
        spheres = leaf & np.asarray(sphere_slots)[np.where(leaf, nodes["child"], 0)]
        nodes["count"][spheres] *= -1
    return nodes, len(levels)


# Children per wide node: the lanes of layout.WIDE_BVH_NODE.
WIDTH = 8
# Triangles a merged leaf may hold: the lanes of layout.TRIANGLE_BLOCK.
MAX_LEAF = 8
# Spheres a merged leaf may hold: the kernel tests them one after another, so no more than the
# binary builders put in a leaf (max_leaf_size).
MAX_SPHERE_LEAF = 4
# A subtree is merged only if its box's surface area is at most this times the summed areas of
# the leaves it would otherwise be (rays enter a box in proportion to its area, so that sum is
# the leaf tests it costs). Two walls meeting at a corner would merge into a leaf spanning the
# room, entered by every ray instead of a third of them each: veach-bidir's room, 11 % of its
# expected leaf tests (docs/performance.md, "Eleventh pass"). Slightly larger merged boxes are
# still worth their saved lanes and nodes on fine meshes; 1.5 would merge the walls again.
MERGED_AREA_LIMIT = 1.25


def _greedy_slots(roots, area, index, interior, width=WIDTH):
    """Per binary node of `roots`, its wide node's `width` lanes as (binary node, side) slot
    references (-1: an empty lane): its two children, then, while a lane is free, the interior
    lane of largest surface area replaced by that child's two children."""
    n = len(roots)
    nodes = np.full((n, width), -1, np.int64)
    sides = np.zeros((n, width), np.int64)
    nodes[:, :2] = roots[:, None]
    sides[:, 1] = 1
    rows = np.arange(n)
    for free in range(2, width):
        valid = nodes[:, :free] >= 0
        node, side = np.maximum(nodes[:, :free], 0), sides[:, :free]
        expandable = valid & interior[node, side]
        score = np.where(expandable, area[node, side], -1.0)
        pick = np.argmax(score, axis=1)
        grow = expandable[rows, pick]
        child = index[node[rows, pick], side[rows, pick]]
        # The picked lane takes the child's left child, the free lane its right child.
        nodes[grow, pick[grow]] = child[grow]
        sides[grow, pick[grow]] = 0
        nodes[grow, free] = child[grow]
        sides[grow, free] = 1
    return nodes, sides


def _merge_small_subtrees(index, count, area, sphere_slots):
    """(index, count) of the binary tree's slots with every interior child whose subtree holds at
    most MAX_LEAF triangles or MAX_SPHERE_LEAF spheres, not both, in contiguous slots, and whose box
    (`area`: per slot) is at most MERGED_AREA_LIMIT times the areas of the leaves below it, made a
    leaf over those slots. (PLOC lays every subtree's primitives out contiguously; the binned
    builder does not always, and its subtrees that are not stay as they are.)"""
    interior = (count == 0) & (index >= 0)
    leaf = count > 0
    sub_count = np.where(leaf, count, 0).astype(np.int64)
    first = np.where(leaf, index.astype(np.int64), np.iinfo(np.int64).max)
    last = np.where(leaf, index + count - 1, -1).astype(np.int64)
    spheres = np.zeros(index.shape, np.int64)   # spheres below each slot
    if sphere_slots is not None and np.any(sphere_slots):
        spheres[leaf] = np.where(np.asarray(sphere_slots)[index[leaf]], count[leaf], 0)
    leaf_area = np.where(leaf, area, 0.0)   # summed areas of the leaves each slot becomes
    merge = np.zeros(index.shape, bool)
    for level in _binary_levels(index, interior)[::-1]:   # bottom-up: children before parents
        for side in (0, 1):
            parents = level[interior[level, side]]
            child = index[parents, side]
            slot = (parents, side)
            sub_count[slot] = sub_count[child].sum(axis=1)
            first[slot] = first[child].min(axis=1)
            last[slot] = last[child].max(axis=1)
            spheres[slot] = spheres[child].sum(axis=1)
            apart = leaf_area[child].sum(axis=1)
            limit = np.where(spheres[slot] == 0, MAX_LEAF,
                             np.where(spheres[slot] == sub_count[slot], MAX_SPHERE_LEAF, 0))   # 0: mixed
            merge[slot] = ((sub_count[slot] <= limit) & (last[slot] - first[slot] + 1 == sub_count[slot])
                           & (area[slot] <= MERGED_AREA_LIMIT * apart))
            leaf_area[slot] = np.where(merge[slot], area[slot], apart)
    return np.where(merge, first, index), np.where(merge, sub_count, count)


def _binary_levels(index, interior):
    """The binary tree's nodes level by level from the root (a list of index arrays)."""
    levels, frontier = [], np.array([0])
    while frontier.size:
        levels.append(frontier)
        frontier = index[frontier][interior[frontier]]
    return levels


def _slot_areas(lo, hi):
    """Surface area (half) of every child slot's box; 0 for empty slots."""
    with np.errstate(invalid="ignore"):   # empty slots: inf - inf
        extent = hi - lo
    extent = np.where(np.isfinite(extent), extent, 0.0)
    return extent[..., 0] * extent[..., 1] + extent[..., 1] * extent[..., 2] + extent[..., 2] * extent[..., 0]


def _binary_slots(nodes):
    """Per binary node and side (0 left, 1 right): box corners, index and primitive count."""
    lo = np.stack([nodes["left_lo"][:, :3], nodes["right_lo"][:, :3]], axis=1)
    hi = np.stack([nodes["left_hi"][:, :3], nodes["right_hi"][:, :3]], axis=1)
    index = np.stack([nodes["left_lo"].view(np.int32)[:, 3], nodes["right_lo"].view(np.int32)[:, 3]], axis=1)
    count = np.stack([nodes["left_hi"].view(np.int32)[:, 3], nodes["right_hi"].view(np.int32)[:, 3]], axis=1)
    return lo, hi, index, count


def _assemble(node, side, wide_of, lo, hi, index, count):
    """Write the wide nodes (lanes `node`, `side` (W, WIDTH) in wide node order). Empty lanes get
    the never-entered box (all corners at +inf, as the binary tree's empty slots), child -1 and
    count 0; interior children are renumbered."""
    nodes = np.zeros(len(node), layout.WIDE_BVH_NODE)
    for name in ("lo_x", "hi_x", "lo_y", "hi_y", "lo_z", "hi_z"):
        nodes[name] = np.inf
    nodes["child"] = -1
    valid = (node >= 0)
    valid[valid] = (index[node[valid], side[valid]] >= 0) | (count[node[valid], side[valid]] > 0)
    rows, lanes = np.nonzero(valid)
    k, s = node[rows, lanes], side[rows, lanes]
    for axis, (lo_name, hi_name) in enumerate((("lo_x", "hi_x"), ("lo_y", "hi_y"), ("lo_z", "hi_z"))):
        nodes[lo_name][rows, lanes] = lo[k, s, axis]
        nodes[hi_name][rows, lanes] = hi[k, s, axis]
    slot_count = count[k, s]
    child = index[k, s].astype(np.int64)
    child[slot_count == 0] = wide_of[child[slot_count == 0]]
    nodes["child"][rows, lanes] = child
    nodes["count"][rows, lanes] = slot_count
    return nodes
