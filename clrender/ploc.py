"""BVH build by Parallel Locally-Ordered Clustering (PLOC; Meister and Bittner 2018), vectorised
with numpy: the builder scenes use, several times faster than the top-down binned SAH of bvh.py
on large meshes, for trees of the same SAH cost (docs/performance.md, "Start-up at scale").

Primitives are sorted along a Morton curve of their box centres. Then, as long as more than one
cluster is left, every cluster looks for its nearest neighbour among the RADIUS clusters on
each side of it in that order (distance: the surface area of the box around both), and every
pair of mutual nearest neighbours merges into a new node in the place of the left one. A pass
works on whole arrays, so the Python-level iterations are the passes (tens), never the nodes.
Equal distances are told apart by a hash of the pair, so that chains of equal distances (a
regular grid, coincident triangles) still hold many mutual pairs and a pass merges a large
fraction of the clusters.

The binary tree this makes has one primitive per leaf. A bottom-up pass then turns a subtree
into one leaf where the SAH says so (at most max_leaf_size primitives, never mixing triangles and
spheres), and a top-down pass lays the leaves' primitives out contiguously, giving bvh.Bvh's
node layout. A tree deeper than bvh.MAX_DEPTH (a pathological distribution) is built by bvh.py's
builder instead, whose median splits bound the depth.
"""
import numpy as np

from . import layout
from .bvh import (INTERSECTION_COST, MAX_DEPTH, TRAVERSAL_COST, _SLOTS, Bvh, _empty_nodes,
                  build_bvh, primitive_bounds)

# Neighbours searched on each side: Meister and Bittner's trees gain little beyond 8 to 16.
RADIUS = 8
# Clusters per block of the neighbour search: its working set (a few hundred kB) fits a core's L2.
BLOCK = 1 << 14
_GOLDEN = np.uint32(0x9E3779B9)   # Fibonacci hashing: positions to scattered bits


def build_ploc_bvh(v0, v1, v2, max_leaf_size=4, spheres=None, radius=RADIUS) -> Bvh:
    """A two-child BVH over triangles and spheres, numbered and laid out as bvh.build_bvh's."""
    if max_leaf_size < 1 or radius < 1:
        raise ValueError("need max_leaf_size >= 1 and radius >= 1")
    lo, hi, n_triangles = primitive_bounds(v0, v1, v2, spheres)
    n = lo.shape[1]
    if n < 2:
        return build_bvh(v0, v1, v2, max_leaf_size, spheres=spheres)
    order = _morton_order(lo, hi)
    merges = _Merges(lo, hi)
    del lo, hi   # copied into merges: a large mesh's boxes are held once
    _cluster(merges, order.astype(np.int32), radius)
    tree = _layout(merges, np.arange(n) >= n_triangles, max_leaf_size)
    if tree.depth > MAX_DEPTH:
        return build_bvh(v0, v1, v2, max_leaf_size, spheres=spheres)
    return tree


def _morton_order(lo, hi):
    """Primitive indices sorted by the 63-bit Morton code of their box centres (ties by index)."""
    centre = lo + hi
    low = centre.min(axis=1, keepdims=True)
    # One scale for all axes: stretching a flat scene's thin axis would scatter neighbours.
    extent = float((centre.max(axis=1, keepdims=True) - low).max())
    scale = np.float32((2**21 - 1) / extent if extent > 0 else 0)
    code = np.zeros(lo.shape[1], np.uint64)
    for axis in range(3):
        cell = ((centre[axis] - low[axis]) * scale).astype(np.uint64)
        code |= _spread_bits(np.minimum(cell, 2**21 - 1)) << np.uint64(axis)
    return np.argsort(code, kind="stable")


def _spread_bits(x):
    """21-bit integers with two zero bits inserted after every bit."""
    for shift, mask in ((32, 0x1F00000000FFFF), (16, 0x1F0000FF0000FF), (8, 0x100F00F00F00F00F),
                        (4, 0x10C30C30C30C30C3), (2, 0x1249249249249249)):
        x = (x | (x << np.uint64(shift))) & np.uint64(mask)
    return x


class _Merges:
    """The tree's nodes: primitives 0 .. n - 1, then the internal nodes numbered n, n + 1, ... in
    the order they were made (children always before parents; the root last), and the passes
    that made them."""

    def __init__(self, lo, hi):
        n = lo.shape[1]
        self.n = n
        self.lo = np.empty((3, 2 * n - 1), np.float32)   # box of every node
        self.hi = np.empty((3, 2 * n - 1), np.float32)
        self.lo[:, :n], self.hi[:, :n] = lo, hi
        self.left = np.empty(n - 1, np.int32)    # children of internal node n + i
        self.right = np.empty(n - 1, np.int32)
        self.passes = [0]                        # first internal node (- n) of each pass, then the end


def _cluster(merges, node, radius):
    """Merge clusters (node numbers `node`, primitives in curve order) until one is left."""
    lo, hi = merges.lo[:, node], merges.hi[:, node]
    made = 0
    while len(node) > 1:
        neighbour = _nearest_neighbours(lo, hi, radius)
        position = np.arange(len(node))
        mutual = neighbour[neighbour] == position
        keep_left = mutual & (position < neighbour)
        first = np.flatnonzero(keep_left)
        second = neighbour[first]
        count = first.size
        new = slice(made, made + count)
        merges.left[new], merges.right[new] = node[first], node[second]
        lo[:, first] = np.minimum(lo[:, first], lo[:, second])
        hi[:, first] = np.maximum(hi[:, first], hi[:, second])
        merges.lo[:, merges.n + made:merges.n + made + count] = lo[:, first]
        merges.hi[:, merges.n + made:merges.n + made + count] = hi[:, first]
        node[first] = merges.n + np.arange(made, made + count)
        made += count
        merges.passes.append(made)
        kept = ~mutual | keep_left
        lo, hi, node = lo[:, kept], hi[:, kept], node[kept]


def _nearest_neighbours(lo, hi, radius, block=BLOCK):
    """Per cluster, the position of the one within `radius` places whose merged box has the
    least surface area, found block by block (each block's arrays stay in the cache)."""
    m = lo.shape[1]
    neighbour = np.empty(m, np.int32)
    for start in range(0, m, block):
        stop = min(start + block, m)
        window = slice(max(start - radius, 0), min(stop + radius, m))
        found = _window_neighbours(np.ascontiguousarray(lo[:, window]), np.ascontiguousarray(hi[:, window]),
                                   radius, window.start)
        neighbour[start:stop] = found[start - window.start:stop - window.start]
    return neighbour


def _window_neighbours(lo, hi, radius, first):
    """_nearest_neighbours within one window of clusters, the first at position `first`; right
    only for those with all their candidates in the window. Equal areas are ranked by a factor
    per pair just above 1 (the product of a hashed factor per cluster position: the same seen
    from both ends)."""
    m = lo.shape[1]
    position = np.arange(first, first + m, dtype=np.int32)
    jitter = 1 + (position.view(np.uint32) * _GOLDEN >> np.uint32(20)).astype(np.float32) * np.float32(2**-23)
    best = np.full(m, np.inf, np.float32)
    neighbour = np.zeros(m, np.int32)
    for k in range(1, min(radius, m - 1) + 1):
        distance = _half_area(np.minimum(lo[:, :-k], lo[:, k:]), np.maximum(hi[:, :-k], hi[:, k:]))
        distance *= jitter[:-k]
        distance *= jitter[k:]
        # Pair (i, i + k): a candidate for i (the one k places right) and for i + k (k left).
        for cluster, other in ((slice(0, m - k), position[k:]), (slice(k, m), position[:m - k])):
            closer = distance < best[cluster]
            np.copyto(best[cluster], distance, where=closer)
            np.copyto(neighbour[cluster], other, where=closer)
    return neighbour


def _half_area(lo, hi):
    d = hi - lo
    return d[0] * d[1] + d[1] * d[2] + d[2] * d[0]


def _layout(merges, is_sphere, max_leaf_size):
    """The Bvh of the merge tree: subtrees collapsed into leaves where the SAH says so, leaf
    primitives contiguous in prim_order (the tree's left-to-right order)."""
    n = merges.n
    root = 2 * n - 2
    left, right = merges.left, merges.right
    count = np.ones(2 * n - 1, np.int32)
    spheres = np.zeros(2 * n - 1 if is_sphere.any() else 0, np.int32)   # none: every node is pure
    if len(spheres):
        spheres[:n] = is_sphere
    cost = np.empty(2 * n - 1, np.float32)
    cost[:n] = INTERSECTION_COST * _half_area(merges.lo[:, :n], merges.hi[:, :n])
    area = _half_area(merges.lo[:, n:], merges.hi[:, n:])
    leaf = np.zeros(2 * n - 1, bool)
    for first, last in zip(merges.passes[:-1], merges.passes[1:]):   # bottom-up
        at = slice(first, last)
        l, r, node = left[at], right[at], slice(n + first, n + last)
        count[node] = count[l] + count[r]
        pure = True
        if len(spheres):
            spheres[node] = spheres[l] + spheres[r]
            pure = (spheres[node] == 0) | (spheres[node] == count[node])
        split_cost = TRAVERSAL_COST * area[at] + cost[l] + cost[r]
        leaf_cost = INTERSECTION_COST * count[node] * area[at]
        leaf[node] = pure & (count[node] <= max_leaf_size) & (leaf_cost <= split_cost)
        cost[node] = np.where(leaf[node], leaf_cost, split_cost)

    # Top-down: first slot in prim_order, depth, and whether a leaf above holds the node.
    offset = np.zeros(2 * n - 1, np.int32)
    depth = np.ones(2 * n - 1, np.int32)
    inside = np.zeros(2 * n - 1, bool)
    for first, last in zip(merges.passes[-2::-1], merges.passes[:0:-1]):
        at = slice(first, last)
        l, r, node = left[at], right[at], slice(n + first, n + last)
        below = inside[node] | leaf[node]
        offset[l], offset[r] = offset[node], offset[node] + count[l]
        depth[l], depth[r] = depth[node] + 1, depth[node] + 1
        inside[l], inside[r] = below, below
    prim_order = np.empty(n, np.int32)
    prim_order[offset[:n]] = np.arange(n, dtype=np.int32)
    if leaf[root]:
        nodes = _empty_nodes(1)
        _write_slot(nodes, 0, merges, [root], [0], [n])
        return Bvh(nodes, prim_order, 1)

    interior = np.flatnonzero(~leaf[n:] & ~inside[n:])[::-1]   # internal node - n, root first
    number = np.full(n - 1, -1, np.int32)
    number[interior] = np.arange(interior.size)
    nodes = np.empty(interior.size, layout.BVH_NODE)   # every slot is written below
    for side, children in enumerate((left[interior], right[interior])):
        is_leaf = (children < n) | leaf[children]
        index = np.where(is_leaf, offset[children], number[np.maximum(children - n, 0)])
        _write_slot(nodes, side, merges, children, index, np.where(is_leaf, count[children], 0))
    return Bvh(nodes, prim_order, int(depth[n + interior].max()))


def _write_slot(nodes, side, merges, children, index, count):
    """Fill one slot (0 left, 1 right) of every node: the box of node `children` of the merge
    tree, `index` and `count`. Axis by axis: each a gather from one contiguous row."""
    lo_name, hi_name = _SLOTS[side]
    for axis in range(3):
        nodes[lo_name][:, axis] = merges.lo[axis, children]
        nodes[hi_name][:, axis] = merges.hi[axis, children]
    nodes[lo_name].view(np.int32)[:, 3] = index
    nodes[hi_name].view(np.int32)[:, 3] = count

