"""The BVH leaves' triangles as the kernel intersects them: eight at once, from one
layout.TRIANGLE_BLOCK per leaf (kernels/bvh.h, intersect_triangle_block)."""
import numpy as np

from . import host_memory, layout

LANES = 8
LEAVES_AT_A_TIME = 1 << 12


def triangle_blocks(nodes, triangles):
    """(nodes, blocks): the wide tree (layout.WIDE_BVH_NODE), changed in place (no second copy of
    a large scene's nodes), with each triangle leaf's `child` turned from its first primitive
    slot into the index of its block, and the blocks, in the order of the leaves' lanes. A
    block's lanes past the leaf's count repeat its last triangle. `triangles`: the primitive
    slots (layout.TRIANGLE). There is always at least one block (an empty buffer cannot be
    passed to a kernel)."""
    leaf = nodes["count"] > 0
    first, count = nodes["child"][leaf], nodes["count"][leaf]
    if np.any(count > LANES):
        raise ValueError(f"a leaf of {int(count.max())} triangles; a block holds {LANES}")
    blocks = host_memory.zeros(max(len(first), 1), layout.TRIANGLE_BLOCK)
    records = triangles.view(np.float32).reshape(len(triangles), 3, 4)   # v0, e1, e2 as xyzw rows
    lanes = blocks.view(np.float32).reshape(len(blocks), -1)[:, :9 * LANES].reshape(len(blocks), 9, LANES)
    # LEAVES_AT_A_TIME leaves at a time: the gathered records are a temporary of a block's size,
    # not one as large as all the blocks (a tenth of a 3M-triangle scene's peak memory).
    for start in range(0, len(first), LEAVES_AT_A_TIME):
        leaves = slice(start, start + LEAVES_AT_A_TIME)
        slots = first[leaves, None] + np.minimum(np.arange(LANES), count[leaves, None] - 1)   # (leaves, LANES)
        blocks["slot"][leaves] = slots
        # One gather of the slots' whole records as float32 words (np.take would copy a strided
        # view of them whole first), then each block's (field, axis) rows of lanes: a transpose,
        # not a fancy index per component.
        words = np.take(records, slots, axis=0)[..., :3]
        lanes[leaves] = words.reshape(len(slots), LANES, 9).transpose(0, 2, 1)
    nodes["child"][leaf] = np.arange(len(first))
    return nodes, blocks
