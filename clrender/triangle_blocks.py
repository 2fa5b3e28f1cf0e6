"""The BVH leaves' triangles as the kernel intersects them: eight at once, from one
layout.TRIANGLE_BLOCK per leaf (kernels/bvh.h, intersect_triangle_block)."""
import numpy as np

from . import host_memory, layout

LANES = 8


def triangle_blocks(nodes, triangles):
    """(nodes, blocks): the wide tree (layout.WIDE_BVH_NODE) with each triangle leaf's `child`
    turned from its first primitive slot into the index of its block, and the blocks, in the
    order of the leaves' lanes. A block's lanes past the leaf's count repeat its last triangle.
    `triangles`: the primitive slots (layout.TRIANGLE). There is always at least one block (an
    empty buffer cannot be passed to a kernel)."""
    nodes = host_memory.copy(nodes)
    leaf = nodes["count"] > 0
    first, count = nodes["child"][leaf], nodes["count"][leaf]
    if np.any(count > LANES):
        raise ValueError(f"a leaf of {int(count.max())} triangles; a block holds {LANES}")
    blocks = host_memory.zeros(max(len(first), 1), layout.TRIANGLE_BLOCK)
    slots = first[:, None] + np.minimum(np.arange(LANES), count[:, None] - 1)   # (leaves, LANES)
    blocks["slot"][:len(first)] = slots
    # One gather of the slots' records as float32 words (v0, e1, e2 as xyzw rows), then each
    # block's (field, axis) rows of lanes: a transpose, not a fancy index per component.
    words = np.take(triangles.view(np.float32).reshape(len(triangles), 3, 4)[:, :, :3], slots, axis=0)
    lanes = blocks.view(np.float32).reshape(len(blocks), -1)[:len(first), :9 * LANES]
    lanes.reshape(len(first), 9, LANES)[:] = words.reshape(len(first), LANES, 9).transpose(0, 2, 1)
    nodes["child"][leaf] = np.arange(len(first))
    return nodes, blocks
