"""Tests for clrender.ploc (test_bvh_build checks its trees' invariants and hits on every scene
there, as the binned builder's): triangles and spheres kept apart, the SAH leaf choice, depth fallback and determinism."""
import numpy as np
import pytest

from clrender import bvh as bvh_mod
from clrender import ploc
from clrender.bvh import build_bvh
from test_bvh_build import assert_same_hits, check_tree, child_slots, exponential_spacing, soup


@pytest.mark.parametrize("radius", [1, 3, 16])
def test_search_radius(radius):
    v0, v1, v2 = soup(1500, 21, size=0.05)
    tree = ploc.build_ploc_bvh(v0, v1, v2, radius=radius)
    check_tree(tree, v0, v1, v2, 4)
    assert_same_hits(tree, v0, v1, v2, n_rays=1000)


def test_equal_distances_still_merge_many_per_pass():
    """A regular grid (every neighbour at the same distance) must not degrade into one merge per
    pass: the pair hash breaks the ties. 2 * 40 * 40 triangles in far fewer passes than that."""
    from test_bvh_build import plane
    v0, v1, v2 = plane(40)
    lo, hi, _ = bvh_mod.primitive_bounds(v0, v1, v2)
    order = ploc._morton_order(lo, hi)
    merges = ploc._Merges(lo, hi)
    ploc._cluster(merges, order.astype(np.int32), ploc.RADIUS)
    assert len(merges.passes) - 1 < 60


def test_leaves_never_mix_triangles_and_spheres():
    rng = np.random.default_rng(3)
    v0, v1, v2 = soup(400, 22, size=0.05)
    centres, radii = rng.random((300, 3)), np.full(300, 0.02)
    tree = ploc.build_ploc_bvh(v0, v1, v2, spheres=(centres, radii))
    lo, hi, index, count = child_slots(tree)
    leaf = count > 0
    prims = tree.prim_order[np.concatenate([np.arange(f, f + s) for f, s in zip(index[leaf], count[leaf])])]
    kinds = np.add.reduceat(prims >= len(v0), np.cumsum(count[leaf]) - count[leaf])
    assert np.all((kinds == 0) | (kinds == count[leaf]))
    assert np.count_nonzero(kinds) > 0 and np.count_nonzero(kinds == 0) > 0
    # Leaf boxes contain the boxes of their spheres (as bvh.sphere_bounds rounds them).
    sphere_lo, sphere_hi = bvh_mod.sphere_bounds(centres, radii)
    box_lo, box_hi = np.repeat(lo[leaf], count[leaf], axis=0), np.repeat(hi[leaf], count[leaf], axis=0)
    spheres = prims >= len(v0)
    assert np.all(box_lo[spheres] <= sphere_lo.T[prims[spheres] - len(v0)])
    assert np.all(sphere_hi.T[prims[spheres] - len(v0)] <= box_hi[spheres])


def test_sah_leaf_choice_matches_split_cost():
    """Two far-apart pairs of coincident triangles: each pair is cheaper as one leaf than split
    (the split costs a node visit and gains nothing), the two pairs cheaper apart."""
    a = soup(1, 30, size=0.01)
    b = tuple(v + 100.0 for v in a)
    v0, v1, v2 = (np.concatenate([x, x, y, y]) for x, y in zip(a, b))
    tree = ploc.build_ploc_bvh(v0, v1, v2)
    lo, hi, index, count = child_slots(tree)
    assert len(tree.nodes) == 1 and sorted(count[0].tolist()) == [2, 2]


def test_too_deep_falls_back_to_binned_sah(monkeypatch):
    v0, v1, v2 = exponential_spacing()
    monkeypatch.setattr(ploc, "MAX_DEPTH", 12)
    monkeypatch.setattr(bvh_mod, "MAX_DEPTH", 12)
    tree = ploc.build_ploc_bvh(v0, v1, v2)
    assert tree.depth <= 12
    reference = build_bvh(v0, v1, v2)
    assert tree.nodes.tobytes() == reference.nodes.tobytes()
    check_tree(tree, v0, v1, v2, 4)


def test_build_is_deterministic():
    v0, v1, v2 = soup(3000, 15)
    a, b = ploc.build_ploc_bvh(v0, v1, v2), ploc.build_ploc_bvh(v0, v1, v2)
    assert np.array_equal(a.prim_order, b.prim_order)
    assert a.nodes.tobytes() == b.nodes.tobytes()


def test_invalid_input():
    v0, v1, v2 = soup(10, 14)
    with pytest.raises(ValueError):
        ploc.build_ploc_bvh(v0, v1, v2[:5])
    with pytest.raises(ValueError):
        ploc.build_ploc_bvh(v0, v1, v2, max_leaf_size=0)
