"""The eight-wide tree collapsed from the binary SAH tree: structure and bounds."""
import numpy as np
import pytest

from clrender.bvh import MAX_DEPTH, build_bvh
from clrender.wide_bvh import MAX_LEAF, MAX_SPHERE_LEAF, WIDTH, collapse

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
