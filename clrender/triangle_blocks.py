"""The BVH leaves' triangles as the kernel intersects them: eight at once, from one
layout.TRIANGLE_BLOCK per leaf (kernels/bvh.h, intersect_triangle_block)."""
import numpy as np

from . import host_memory, layout

LANES = 8
LEAVES_AT_A_TIME = 1 << 12


def triangle_edges(v0, v1, v2, triangles):
    """(v0, e1, e2) of these triangles (indices into the float32 corners v0, v1, v2), float32.
    Edges are differences of the float32 corners, not rounded float64 differences: then v0 + e1
    gives back the float32 corner (exactly where the corners are within a factor of 2, Sterbenz),
    so triangles sharing an edge share its ends. Far from the origin, rounded float64 edges leave
    cracks and overlaps of half an ulp of the position between neighbours."""
    a = np.take(v0, triangles, axis=0)
    return a, np.take(v1, triangles, axis=0) - a, np.take(v2, triangles, axis=0) - a


def triangle_blocks(nodes, v0, v1, v2, order):
    """(nodes, blocks): the wide tree (layout.WIDE_BVH_NODE), changed in place (no second copy of
    a large scene's nodes), with each triangle leaf's `child` turned from its first primitive
    slot into the index of its block, and the blocks, in the order of the leaves' lanes. A
    block's lanes past the leaf's count repeat its last triangle. Slot k holds triangle order[k]
    of the float32 corners v0, v1, v2. The blocks are the only copy of the triangles' geometry
    the kernel has (slot_triangles reads it back). There is always at least one block (an empty
    buffer cannot be passed to a kernel)."""
    leaf = nodes["count"] > 0
    first, count = nodes["child"][leaf], nodes["count"][leaf]
    if np.any(count > LANES):
        raise ValueError(f"a leaf of {int(count.max())} triangles; a block holds {LANES}")
    blocks = host_memory.zeros(max(len(first), 1), layout.TRIANGLE_BLOCK)
    v0, v1, v2 = (np.asarray(v, np.float32) for v in (v0, v1, v2))
    order = np.asarray(order)
    lanes = blocks.view(np.float32).reshape(len(blocks), -1)[:, :9 * LANES].reshape(len(blocks), 9, LANES)
    # LEAVES_AT_A_TIME leaves at a time: the gathered corners are a temporary of a block's size,
    # not one as large as all the blocks (a tenth of a 3M-triangle scene's peak memory).
    for start in range(0, len(first), LEAVES_AT_A_TIME):
        leaves = slice(start, start + LEAVES_AT_A_TIME)
        slots = first[leaves, None] + np.minimum(np.arange(LANES), count[leaves, None] - 1)   # (leaves, LANES)
        blocks["slot"][leaves] = slots
        # Each block's (field, axis) rows of lanes: a transpose, not a fancy index per component.
        words = np.stack(triangle_edges(v0, v1, v2, order[slots]), axis=2)   # (leaves, LANES, field, axis)
        lanes[leaves] = words.reshape(len(slots), LANES, 9).transpose(0, 2, 1)
    nodes["child"][leaf] = np.arange(len(first))
    return nodes, blocks


def slot_triangles(blocks, slot_count):
    """(v0, e1, e2): float32 (slot_count, 3) each, the triangle of every primitive slot as the
    blocks hold it (zeros in sphere slots): the kernel's geometry, for checks on the host."""
    lanes = blocks.view(np.float32).reshape(len(blocks), -1)[:, :9 * LANES].reshape(len(blocks), 3, 3, LANES)
    v0, e1, e2 = (np.zeros((slot_count, 3), np.float32) for _ in range(3))
    slots = blocks["slot"].reshape(-1)
    for field, out in enumerate((v0, e1, e2)):
        out[slots] = lanes[:, field].transpose(0, 2, 1).reshape(-1, 3)
    return v0, e1, e2
