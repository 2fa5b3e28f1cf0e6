"""The eight-wide tree collapsed from the binary SAH tree: structure and bounds."""
import functools

import numpy as np
import pytest

from clrender.bvh import MAX_DEPTH, build_bvh
from clrender.wide_bvh import LEAF_COST, MAX_LEAF, MAX_SPHERE_LEAF, NODE_COST, WIDTH, collapse

KERNEL_STACK = 435  # BVH_STACK_SIZE in kernels/bvh.h


@pytest.mark.parametrize("count", [0, 1, 2, 5, 17, 3000])
def test_wide_tree_covers_every_triangle_once_inside_its_boxes(count):
    rng = np.random.default_rng(count)
    v0 = rng.uniform(-5, 5, (count, 3))
    v1, v2 = v0 + rng.normal(0, 0.4, (count, 3)), v0 + rng.normal(0, 0.4, (count, 3))
    binary = build_bvh(v0, v1, v2)
    nodes, depth = collapse(binary)
    child, lanes_count = nodes["child"], nodes["count"]
    leaf = lanes_count > 0
    covered = np.concatenate([np.arange(c, c + n) for c, n in zip(child[leaf], lanes_count[leaf])] or [[]])
    assert np.array_equal(np.sort(covered), np.arange(count))  # every slot exactly once
    interior = (lanes_count == 0) & (child >= 0)
    # every wide node but the root is the child of exactly one lane
    assert np.array_equal(np.sort(child[interior]), np.arange(1, len(nodes)))
    empty = (lanes_count == 0) & (child < 0)
    for name in ("lo_x", "hi_x", "lo_y", "hi_y", "lo_z", "hi_z"):
        assert np.all(nodes[name][empty] == np.inf)
    # leaf boxes contain their triangles (in the reordered slots)
    corners = np.stack([v0, v1, v2], axis=1)[binary.prim_order]
    rows, lanes = np.nonzero(leaf)
    for r, l in zip(rows, lanes):
        tri = corners[child[r, l]:child[r, l] + lanes_count[r, l]].reshape(-1, 3)
        lo = [nodes[n][r, l] for n in ("lo_x", "lo_y", "lo_z")]
        hi = [nodes[n][r, l] for n in ("hi_x", "hi_y", "hi_z")]
        assert np.all(tri >= lo) and np.all(tri <= hi)
    # Each wide level pushes at most WIDTH - 1 siblings.
    assert depth <= binary.depth and (WIDTH - 1) * (MAX_DEPTH - 1) + 1 <= KERNEL_STACK


def _leaf_boxes(nodes):
    leaf = nodes["count"] > 0
    lo = np.stack([nodes[n][leaf] for n in ("lo_x", "lo_y", "lo_z")], axis=-1)
    hi = np.stack([nodes[n][leaf] for n in ("hi_x", "hi_y", "hi_z")], axis=-1)
    return lo, hi, nodes["count"][leaf]


def _square(corner, u, v):
    """Two triangles (v0, v1, v2) spanning the square corner + [0, 1] u + [0, 1] v."""
    corner, u, v = (np.array(a, float) for a in (corner, u, v))
    return (np.array([corner, corner + u + v]), np.array([corner + u, corner + v]),
            np.array([corner + u + v, corner + u]))


@pytest.mark.parametrize("builder", ["binned", "ploc"])
def test_small_subtrees_merge_into_one_leaf_unless_its_box_is_far_larger(builder):
    from clrender.ploc import build_ploc_bvh
    build = build_bvh if builder == "binned" else build_ploc_bvh
    # A floor and a wall meeting at an edge (a leaf over both would span their whole cube and be
    # entered by about twice the rays), and far away a strip of eight adjacent small triangles
    # (merged into one leaf, a TriangleBlock's eight lanes: their box is the sum of the pairs').
    strip = [_square((40 + 0.1 * i, 40, 40), (0.1, 0, 0), (0, 0.1, 0)) for i in range(4)]
    parts = [_square((0, 0, 0), (8, 0, 0), (0, 8, 0)), _square((0, 0, 0), (8, 0, 0), (0, 0, 8)), *strip]
    v0, v1, v2 = (np.concatenate([p[i] for p in parts]) for i in range(3))
    nodes, _depth = collapse(build(v0, v1, v2, max_leaf_size=2))
    lo, hi, counts = _leaf_boxes(nodes)
    walls = hi[:, 0] <= 8
    assert counts.sum() == 12
    # each wall's leaf is flat: no leaf holds triangles of both
    assert np.all(np.min(hi[walls] - lo[walls], axis=1) == 0)
    assert list(counts[~walls]) == [MAX_LEAF] == [8]


def test_spheres_merge_into_leaves_of_at_most_four():
    # Two rows of eight touching spheres would each merge into one leaf as triangles do; the
    # kernel tests a leaf's spheres one after another, so they stay in leaves of MAX_SPHERE_LEAF.
    centres = np.stack([np.arange(16.0), np.zeros(16), np.zeros(16)], axis=1)
    none = np.zeros((0, 3))
    tree = build_bvh(none, none, none, max_leaf_size=2, spheres=(centres, np.full(16, 0.5)))
    nodes, _depth = collapse(tree, np.ones(16, bool))
    counts = nodes["count"][nodes["count"] != 0]
    assert MAX_SPHERE_LEAF == 4 and list(counts) == [-4] * 4


def _wide_tree_cost(nodes):
    """The SAH cost the collapse minimises, read from its output: each wide node but the root
    costs its box's area (the lane that holds it), each leaf its box's area."""
    lo = np.stack([nodes[n] for n in ("lo_x", "lo_y", "lo_z")], axis=-1)
    hi = np.stack([nodes[n] for n in ("hi_x", "hi_y", "hi_z")], axis=-1)
    valid = nodes["child"] >= 0
    with np.errstate(invalid="ignore"):   # empty lanes: inf - inf
        extent = np.where(valid[..., None], hi - lo, 0.0).astype(np.float64)
    area = extent[..., 0] * extent[..., 1] + extent[..., 1] * extent[..., 2] + extent[..., 2] * extent[..., 0]
    leaf = valid & (nodes["count"] != 0)
    return NODE_COST * area[valid & ~leaf].sum() + LEAF_COST * area[leaf].sum()


def _exhaustive_cost(tree, sphere_slots):
    """The least cost over every wide tree the binary one can be collapsed into, by enumerating
    each wide node's lanes as every cut of its binary subtree into at most WIDTH subtrees (each
    then a leaf, if its primitives are few, contiguous and of one kind, or a wide node)."""
    nodes = tree.nodes
    lo = {0: nodes["left_lo"][:, :3].astype(np.float64), 1: nodes["right_lo"][:, :3].astype(np.float64)}
    hi = {0: nodes["left_hi"][:, :3].astype(np.float64), 1: nodes["right_hi"][:, :3].astype(np.float64)}
    index = {0: nodes["left_lo"].view(np.int32)[:, 3], 1: nodes["right_lo"].view(np.int32)[:, 3]}
    count = {0: nodes["left_hi"].view(np.int32)[:, 3], 1: nodes["right_hi"].view(np.int32)[:, 3]}

    def area(node, side):
        e = hi[side][node] - lo[side][node]
        return e[0] * e[1] + e[1] * e[2] + e[2] * e[0]

    def primitives(node, side):
        if count[side][node] > 0:
            return list(range(index[side][node], index[side][node] + count[side][node]))
        return primitives(index[side][node], 0) + primitives(index[side][node], 1)

    @functools.cache
    def cuts(node, side, lanes):   # every list of at most `lanes` slots covering the slot's subtree
        found = {((node, side),)}
        if count[side][node] == 0 and lanes >= 2:
            child = index[side][node]
            for k in range(1, lanes):
                found |= {a + b for a in cuts(child, 0, k) for b in cuts(child, 1, lanes - k)}
        return frozenset(found)

    @functools.cache
    def one_lane(node, side):   # the least cost of the slot as one lane
        options = []
        prims = primitives(node, side)
        kinds = {bool(sphere_slots[p]) for p in prims}
        limit = MAX_SPHERE_LEAF if kinds == {True} else MAX_LEAF
        if len(kinds) == 1 and len(prims) <= limit and max(prims) - min(prims) + 1 == len(prims):
            options.append(LEAF_COST * area(node, side))
        if count[side][node] == 0:
            options.append(NODE_COST * area(node, side) + wide(index[side][node]))
        return min(options)

    @functools.cache
    def wide(node):   # the least cost below a wide node made from binary node `node`
        return min(sum(one_lane(*slot) for slot in cut)
                   for k in range(1, WIDTH) for cut in
                   [a + b for a in cuts(node, 0, k) for b in cuts(node, 1, WIDTH - k)])

    return wide(0)


@pytest.mark.parametrize("seed", range(4))
def test_collapse_finds_the_cheapest_wide_tree(seed):
    # Binary leaves of one primitive leave the collapse every choice: which subtrees are lanes,
    # which merge into leaves. Ten clusters far apart fill more than the root's lanes, so some
    # slots get one lane while their subtrees would rather have several; each cluster is two
    # groups of small triangles (sometimes near, sometimes apart: one leaf or a node of two);
    # a few spheres (leaves of at most four, never mixed with triangles).
    rng = np.random.default_rng(seed)
    groups = rng.uniform(-100, 100, (10, 1, 3)) + rng.choice([0.5, 15.0], (10, 1, 1)) * rng.normal(size=(10, 2, 3))
    v0 = (groups[:, :, None, :] + rng.normal(0, 0.3, (10, 2, 2, 3))).reshape(-1, 3)
    v1, v2 = v0 + rng.normal(0, 0.3, v0.shape), v0 + rng.normal(0, 0.3, v0.shape)
    centres = rng.uniform(-100, 100, (3, 3))
    tree = build_bvh(v0, v1, v2, max_leaf_size=1, spheres=(centres, np.full(3, 2.0)))
    spheres = tree.prim_order >= len(v0)
    nodes, _depth = collapse(tree, spheres)
    assert _wide_tree_cost(nodes) == pytest.approx(_exhaustive_cost(tree, spheres), rel=1e-5)


def test_wide_nodes_of_a_fine_mesh_use_most_of_their_lanes():
    # The collapse it replaced filled 4.2 of the 8 lanes on the real scenes' trees.
    rng = np.random.default_rng(3)
    p = rng.normal(size=(20000, 3))
    p /= np.linalg.norm(p, axis=1)[:, None]
    nodes, _depth = collapse(build_bvh(p, p + rng.normal(0, 0.01, p.shape), p + rng.normal(0, 0.01, p.shape)))
    assert np.mean(np.count_nonzero(nodes["child"] >= 0, axis=1)) > 6
