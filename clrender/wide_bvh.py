"""The eight-wide BVH the kernel traverses, collapsed from the binary SAH tree (bvh.py).

Each wide node holds up to eight children's boxes in structure-of-arrays form (one child per
float8 lane), so the kernel tests all eight with a handful of vector instructions. Which binary
subtrees become a wide node's lanes, and which become leaves, is chosen to minimise the wide
tree's SAH cost (Ylitie, Karras and Laine 2017, sec. 3.2): a wide node visit and a leaf's block
test each cost their box's surface area, since rays enter boxes in proportion to it (the kernel
tests a leaf's up to eight triangles at once, so a leaf costs the same however many it holds). A
subtree of at most MAX_LEAF triangles (or MAX_SPHERE_LEAF spheres) in contiguous slots may be one
leaf; two walls meeting at a corner stay two leaves, since one leaf's box would span the room.
The greedy collapse it replaced (fill a node's lanes by opening its largest child) used 4.2 of
the 8 lanes on the real scenes' trees, the least-cost trees about 7 (docs/performance.md,
"Twenty-sixth pass"). Bottom-up over the binary levels, then top-down, with numpy (a million
triangles in under a second).
"""
import numpy as np

from . import layout


# Children per wide node: the lanes of layout.WIDE_BVH_NODE.
WIDTH = 8
# Triangles a merged leaf may hold: the lanes of layout.TRIANGLE_BLOCK.
MAX_LEAF = 8
# Spheres a merged leaf may hold: the kernel tests them one after another, so no more than the
# binary builders put in a leaf (max_leaf_size).
MAX_SPHERE_LEAF = 4
# The cost of a wide node's visit and of a leaf's block test per unit of box area (relative: a
# leaf costing twice a node made the same renders, docs/performance.md).
NODE_COST = 1.0
LEAF_COST = 1.0


def collapse(bvh, sphere_slots=None):
    """(nodes, depth): the wide tree (dtype layout.WIDE_BVH_NODE; node 0 the root) of a binary
    Bvh. Leaves keep their primitive ranges (the same reordered primitive slots); a leaf of
    spheres (sphere_slots: bool per slot, True for a sphere) gets its count negated, the
    kernel's primitive-type tag (build_bvh never mixes the two in a leaf)."""
    lo, hi, index, count = _binary_slots(bvh.nodes)
    area = _slot_areas(lo, hi)
    cost, split, as_leaf, first, sub_count = _slot_costs(index, count, area, sphere_slots)
    wide = (count == 0) & (index >= 0) & ~as_leaf   # slots that are a wide node when a lane
    wide_of = np.full(len(bvh.nodes), -1, np.int64)  # binary node -> wide node
    levels, frontier, numbered = [], np.array([0]), 0
    while frontier.size:  # breadth first: a level's wide nodes are numbered together
        wide_of[frontier] = np.arange(numbered, numbered + frontier.size)
        numbered += frontier.size
        node, side = _wide_lanes(frontier, cost, split, index)
        levels.append((node, side))
        below = (node >= 0) & wide[np.maximum(node, 0), side]
        frontier = index[node[below], side[below]]
    slot_node, slot_side = (np.concatenate(lanes) for lanes in zip(*levels))
    merged = as_leaf & (count == 0)   # subtrees that are one leaf: their primitives' range
    nodes = _assemble(slot_node, slot_side, wide_of, lo, hi, np.where(merged, first, index),
                      np.where(merged, sub_count, count))
    if sphere_slots is not None and np.any(sphere_slots):
        leaf = nodes["count"] > 0
        spheres = leaf & np.asarray(sphere_slots)[np.where(leaf, nodes["child"], 0)]
        nodes["count"][spheres] *= -1
    return nodes, len(levels)


def _slot_costs(index, count, area, sphere_slots):
    """Per binary slot (node, side): cost[..., i - 1], the least SAH cost of its subtree given i
    lanes of a wide node (i = 1: itself, a leaf or a wide node of its own; more: lanes shared out
    among its descendants), non-increasing in i; per binary node, split[n, j - 1], the lanes of
    its left slot in its two slots' cheapest sharing of j lanes; as_leaf, whether a slot's
    one-lane form is a leaf (binary leaves, and subtrees that merge into one); and, where it holds
    at most MAX_LEAF primitives, the first slot and count of those primitives."""
    interior = (count == 0) & (index >= 0)
    leaf = count > 0
    sub_count = np.where(leaf, count, 0).astype(np.int32)
    first = np.where(leaf, index, np.iinfo(np.int32).max).astype(np.int32)
    last = np.where(leaf, index + count - 1, -1).astype(np.int32)
    spheres = np.zeros(index.shape, np.int32)   # spheres below each slot
    with_spheres = sphere_slots is not None and np.any(sphere_slots)
    if with_spheres:
        spheres[leaf] = np.where(np.asarray(sphere_slots)[index[leaf]], count[leaf], 0)
    # Empty slots (a tree of one primitive) cost nothing; binary leaves their test whatever i.
    cost = np.empty(index.shape + (WIDTH,), np.float32)
    cost[...] = np.where(leaf, area * LEAF_COST, 0.0)[..., None]
    split = np.zeros((len(index), WIDTH), np.int8)
    as_leaf = leaf.copy()
    for level in _binary_levels(index, interior)[::-1]:   # bottom-up: children before parents
        for side in (0, 1):
            parents = level[interior[level, side]]
            child = index[parents, side]
            # Counts above MAX_LEAF only matter as such: a subtree holding one holds more.
            sub_count[parents, side] = np.minimum(sub_count[child].sum(axis=1), MAX_LEAF + 1)
            few = sub_count[parents, side] <= MAX_LEAF
            slot, few_child = (parents[few], side), child[few]
            first[slot] = first[few_child].min(axis=1)
            last[slot] = last[few_child].max(axis=1)
            if with_spheres:
                spheres[slot] = spheres[few_child].sum(axis=1)
            limit = np.where(spheres[slot] == 0, MAX_LEAF,
                             np.where(spheres[slot] == sub_count[slot], MAX_SPHERE_LEAF, 0))   # 0: mixed
            mergeable = np.zeros(len(parents), bool)
            mergeable[few] = (sub_count[slot] <= limit) & (last[slot] - first[slot] + 1 == sub_count[slot])
            shared, split[child] = _shared_costs(cost, child)
            leaf_cost = np.where(mergeable, area[parents, side] * LEAF_COST, np.inf).astype(np.float32)
            wide_cost = (area[parents, side] * NODE_COST).astype(np.float32) + shared[WIDTH - 1]
            as_leaf[parents, side] = leaf_cost <= wide_cost
            shared[0] = np.minimum(leaf_cost, wide_cost)
            cost[parents, side] = np.minimum.accumulate(shared, axis=0).T
    # The root's two slots, shared as its children's were.
    split[:1] = _shared_costs(cost, np.array([0]))[1]
    return cost, split, as_leaf, first, sub_count


def _shared_costs(cost, nodes):
    """For node n's two slots sharing j lanes, at least one each: (WIDTH, len(nodes)) least
    costs [j - 1, n] (inf for j = 1) and (len(nodes), WIDTH) lanes of the left slot [n, j - 1]."""
    left, right = cost[nodes, 0].T, cost[nodes, 1].T   # [k - 1, n]: the cost with k lanes
    shared = np.full((WIDTH, len(nodes)), np.inf, np.float32)
    split = np.zeros((WIDTH, len(nodes)), np.int8)
    for lanes in range(2, WIDTH + 1):
        for k in range(1, lanes):
            sums = left[k - 1] + right[lanes - k - 1]
            np.copyto(split[lanes - 1], k, where=sums < shared[lanes - 1])
            np.minimum(shared[lanes - 1], sums, out=shared[lanes - 1])
    return shared, split.T


def _wide_lanes(roots, cost, split, index):
    """Per binary node of `roots` (each a wide node), its lanes as (binary node, side) slot
    references, (len(roots), WIDTH), -1 for an empty lane: its two slots share WIDTH lanes as
    cheaply as they can, each slot given several lanes passing them on to its two children in
    turn, until every slot has one. Lanes stay in the tree's left-to-right order."""
    n = len(roots)
    row = np.repeat(np.arange(n), 2)
    node = np.repeat(roots, 2)
    side = np.tile([0, 1], n)
    left = split[roots, WIDTH - 1].astype(np.int64)
    lanes = np.stack([left, WIDTH - left], axis=1).reshape(-1)
    order = np.tile([0, 1 << (WIDTH - 1)], n)   # a slot's place among its node's lanes
    depth = 1
    placed = []   # (row, order, node, side) of the slots that are lanes
    while row.size:
        # A slot with several lanes passes them on where that costs less than keeping one: the
        # fewest lanes at which its cost reaches that of `lanes`.
        several = np.flatnonzero(lanes > 1)
        used = np.ones(len(row), np.int64)
        used[several] = np.argmax(cost[node[several], side[several], :] <=
                                  cost[node[several], side[several], lanes[several] - 1][:, None], axis=1) + 1
        passes = used > 1
        placed.append((row[~passes], order[~passes], node[~passes], side[~passes]))
        child = index[node[passes], side[passes]]
        to_left = split[child, used[passes] - 1].astype(np.int64)
        row, order = np.repeat(row[passes], 2), np.repeat(order[passes], 2)
        order[1::2] += 1 << (WIDTH - 1 - depth)
        node, side = np.repeat(child, 2), np.tile([0, 1], len(child))
        lanes = np.stack([to_left, used[passes] - to_left], axis=1).reshape(-1)
        depth += 1
    row, order, node, side = (np.concatenate(parts) for parts in zip(*placed))
    arranged = np.lexsort((order, row))
    row, node, side = row[arranged], node[arranged], side[arranged]
    lane = np.arange(len(row)) - np.searchsorted(row, row)
    nodes = np.full((n, WIDTH), -1, np.int64)
    sides = np.zeros((n, WIDTH), np.int64)
    nodes[row, lane] = node
    sides[row, lane] = side
    return nodes, sides


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
