"""The four-wide BVH the kernel traverses, collapsed from the binary SAH tree (bvh.py).

Each wide node holds up to four children's boxes in structure-of-arrays form (one child per
float4 lane), so the kernel tests all four with a handful of vector instructions. Collapsing
follows the usual rule (e.g. Wald et al. 2008, "Getting Rid of Packets"): starting from a
binary node's two children, the interior child of largest surface area is replaced by its own
two children until four slots are filled or only leaves remain.
"""
import numpy as np

from . import layout

WIDTH = 4


def collapse(bvh):
    """(nodes, depth): the wide tree (dtype layout.WIDE_BVH_NODE; node 0 the root) of a binary
    Bvh. Leaves keep their primitive ranges (the same reordered triangle slots)."""
    lo, hi, index, count = _binary_slots(bvh.nodes)
    area = _half_area(lo, hi).tolist()
    index, count = index.tolist(), count.tolist()
    wide_children = []  # per wide node: list of (binary node, side) slots
    wide_depth = [1]
    queue = [0]  # binary node whose two children become a wide node's slots
    head = 0
    while head < len(queue):
        node = queue[head]
        depth = wide_depth[head]
        head += 1
        slots = [(node, 0), (node, 1)]
        while len(slots) < WIDTH:
            interior = [s for s in slots if count[s[0]][s[1]] == 0 and index[s[0]][s[1]] >= 0]
            if not interior:
                break
            widest = max(interior, key=lambda s: area[s[0]][s[1]])
            slots.remove(widest)
            child = index[widest[0]][widest[1]]
            slots += [(child, 0), (child, 1)]
        slots = [s for s in slots if count[s[0]][s[1]] > 0 or index[s[0]][s[1]] >= 0]
        wide_children.append(slots)
        for k, s in slots:
            if count[k][s] == 0:
                queue.append(index[k][s])
                wide_depth.append(depth + 1)
    return _assemble(wide_children, queue, lo, hi, index, count), max(wide_depth)


def _binary_slots(nodes):
    """Per binary node and side (0 left, 1 right): box corners, index and primitive count."""
    lo = np.stack([nodes["left_lo"][:, :3], nodes["right_lo"][:, :3]], axis=1)
    hi = np.stack([nodes["left_hi"][:, :3], nodes["right_hi"][:, :3]], axis=1)
    index = np.stack([nodes["left_lo"].view(np.int32)[:, 3], nodes["right_lo"].view(np.int32)[:, 3]], axis=1)
    count = np.stack([nodes["left_hi"].view(np.int32)[:, 3], nodes["right_hi"].view(np.int32)[:, 3]], axis=1)
    return lo, hi, index, count


def _half_area(lo, hi):
    with np.errstate(invalid="ignore"):  # empty slots: inf - inf
        extent = np.maximum(hi - lo, 0.0)
    area = extent[..., 0] * extent[..., 1] + extent[..., 1] * extent[..., 2] + extent[..., 2] * extent[..., 0]
    return np.where(np.isfinite(area), area, 0.0)


def _assemble(wide_children, queue, lo, hi, index, count):
    """Write the wide nodes: empty lanes get the never-entered box (all corners +inf, as the
    binary tree's empty slots), child -1 and count 0; interior children are renumbered."""
    n = len(wide_children)
    wide_index = {binary: i for i, binary in enumerate(queue)}
    nodes = np.zeros(n, layout.WIDE_BVH_NODE)
    for name in ("lo_x", "hi_x", "lo_y", "hi_y", "lo_z", "hi_z"):
        nodes[name] = np.inf
    nodes["child"] = -1
    rows, lanes, k, s = [], [], [], []
    for row, slots in enumerate(wide_children):
        for lane, (node, side) in enumerate(slots):
            rows.append(row)
            lanes.append(lane)
            k.append(node)
            s.append(side)
    rows, lanes, k, s = map(np.asarray, (rows, lanes, k, s))
    if len(rows):
        slot_index = np.asarray(index)[k, s]
        slot_count = np.asarray(count)[k, s]
        for axis, (lo_name, hi_name) in enumerate((("lo_x", "hi_x"), ("lo_y", "hi_y"), ("lo_z", "hi_z"))):
            nodes[lo_name][rows, lanes] = lo[k, s, axis]
            nodes[hi_name][rows, lanes] = hi[k, s, axis]
        interior = slot_count == 0
        child = slot_index.copy()
        child[interior] = [wide_index[b] for b in slot_index[interior].tolist()]
        nodes["child"][rows, lanes] = child
        nodes["count"][rows, lanes] = slot_count
    return nodes
