"""The four-wide BVH the kernel traverses, collapsed from the binary SAH tree (bvh.py).

Each wide node holds up to four children's boxes in structure-of-arrays form (one child per
float4 lane), so the kernel tests all four with a handful of vector instructions. A wide node
takes a binary node's grandchildren: each interior child is replaced by its own two children,
a leaf child stays as it is. Done level by level with numpy (a million triangles in well under
a second).
"""
import numpy as np

from . import layout


def collapse(bvh, sphere_slots=None):
    """(nodes, depth): the wide tree (dtype layout.WIDE_BVH_NODE; node 0 the root) of a binary
    Bvh. Leaves keep their primitive ranges (the same reordered primitive slots); a leaf of
    spheres (sphere_slots: bool per slot, True for a sphere) gets its count negated, the
    kernel's primitive-type tag (build_bvh never mixes the two in a leaf)."""
    lo, hi, index, count = _binary_slots(bvh.nodes)
    interior = (count == 0) & (index >= 0)
    slot_node, slot_side = _grandchild_slots(index, interior)
    wide_of = np.full(len(bvh.nodes), -1, np.int64)  # binary node -> wide node
    order, frontier, depth, numbered = [], np.array([0]), 0, 0
    while frontier.size:  # breadth first: a level's wide nodes are numbered together
        wide_of[frontier] = np.arange(numbered, numbered + frontier.size)
        numbered += frontier.size
        order.append(frontier)
        depth += 1
        node, side = slot_node[frontier], slot_side[frontier]
        valid = node >= 0
        below = valid & interior[np.maximum(node, 0), side]
        frontier = index[node[below], side[below]]
    binary = np.concatenate(order)
    nodes = _assemble(binary, wide_of, slot_node, slot_side, lo, hi, index, count)
    if sphere_slots is not None and np.any(sphere_slots):
        leaf = nodes["count"] > 0
        spheres = leaf & np.asarray(sphere_slots)[np.where(leaf, nodes["child"], 0)]
        nodes["count"][spheres] *= -1
    return nodes, depth


def _grandchild_slots(index, interior):
    """Per binary node, its four wide-node lanes as (binary node, side) slot references, -1 for
    an empty lane: an interior child's two children, or a leaf (or empty) child itself."""
    n = len(index)
    nodes = np.full((n, 4), -1, np.int64)
    sides = np.zeros((n, 4), np.int64)
    for s in (0, 1):
        expand = interior[:, s]
        child = index[:, s]
        nodes[expand, 2 * s] = child[expand]
        nodes[expand, 2 * s + 1] = child[expand]
        sides[expand, 2 * s + 1] = 1
        keep = ~expand
        nodes[keep, 2 * s] = np.nonzero(keep)[0]
        sides[keep, 2 * s] = s
    return nodes, sides


def _binary_slots(nodes):
    """Per binary node and side (0 left, 1 right): box corners, index and primitive count."""
    lo = np.stack([nodes["left_lo"][:, :3], nodes["right_lo"][:, :3]], axis=1)
    hi = np.stack([nodes["left_hi"][:, :3], nodes["right_hi"][:, :3]], axis=1)
    index = np.stack([nodes["left_lo"].view(np.int32)[:, 3], nodes["right_lo"].view(np.int32)[:, 3]], axis=1)
    count = np.stack([nodes["left_hi"].view(np.int32)[:, 3], nodes["right_hi"].view(np.int32)[:, 3]], axis=1)
    return lo, hi, index, count


def _assemble(binary, wide_of, slot_node, slot_side, lo, hi, index, count):
    """Write the wide nodes. Empty lanes get the never-entered box (all corners at +inf, as the
    binary tree's empty slots), child -1 and count 0; interior children are renumbered."""
    nodes = np.zeros(len(binary), layout.WIDE_BVH_NODE)
    for name in ("lo_x", "hi_x", "lo_y", "hi_y", "lo_z", "hi_z"):
        nodes[name] = np.inf
    nodes["child"] = -1
    node, side = slot_node[binary], slot_side[binary]      # (W, 4)
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
