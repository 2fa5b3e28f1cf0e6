"""Tests for clrender.bvh: tree invariants, and nearest hits via the tree vs brute force."""
import numpy as np
import pytest

from clrender import bvh as bvh_mod
from clrender import layout, ploc
from clrender.bvh import build_bvh, intersect_brute_force, ray_triangle_distance


def soup(n, seed, size=0.1):
    rng = np.random.default_rng(seed)
    v0 = rng.random((n, 3))
    return v0, v0 + size * rng.normal(size=(n, 3)), v0 + size * rng.normal(size=(n, 3))


def mixed_sizes(seed):
    """Many small triangles plus a few spanning the whole scene."""
    small = soup(1500, seed, size=0.02)
    big = soup(10, seed + 1, size=2.0)
    return tuple(np.concatenate([s, b]) for s, b in zip(small, big))


def identical(n):
    tri = np.array([[0.1, 0.2, 0.3], [0.9, 0.2, 0.3], [0.1, 0.8, 0.5]])
    return tuple(np.repeat(tri[k:k + 1], n, axis=0) for k in range(3))


def plane(m=30):
    """Flat z=0 grid of 2*m*m triangles: every box has zero z extent."""
    i, j = (a.ravel() for a in np.meshgrid(np.arange(m), np.arange(m), indexing="ij"))
    corner = np.stack([i, j, np.zeros_like(i)], axis=1) / m
    dx, dy = np.array([1.0 / m, 0, 0]), np.array([0, 1.0 / m, 0])
    v0 = np.concatenate([corner, corner + dx + dy])
    v1 = np.concatenate([corner + dx, corner + dy])
    v2 = np.concatenate([corner + dy, corner + dx])
    return v0, v1, v2


def zero_area(seed):
    """Points (all vertices equal), collinear triangles and some regular ones."""
    rng = np.random.default_rng(seed)
    points = rng.random((300, 3))
    start, step = rng.random((300, 3)), 0.05 * rng.normal(size=(300, 3))
    good = soup(300, seed + 1)
    return (np.concatenate([points, start, good[0]]),
            np.concatenate([points, start + step, good[1]]),
            np.concatenate([points, start + 2 * step, good[2]]))


def exponential_spacing(n=600):
    """Centroids at 1.1**i along x: binned SAH peels a few triangles per level, very deep."""
    x = 1.1 ** np.arange(n)
    v0 = np.stack([x, np.zeros(n), np.zeros(n)], axis=1)
    return v0, v0 + [0.0, 1.0, 0.0], v0 + [0.0, 0.0, 1.0]


SCENES = {
    "empty": lambda: soup(0, 0),
    "one": lambda: soup(1, 1),
    "two": lambda: soup(2, 2),
    "three": lambda: soup(3, 3),
    "soup": lambda: soup(2000, 4),
    "mixed_sizes": lambda: mixed_sizes(5),
    "identical": lambda: identical(200),
    "plane": plane,
    "zero_area": lambda: zero_area(6),
    "exponential": exponential_spacing,
}


# ---------------------------------------------------------------------------------------------
# Flattened tree access


def child_slots(tree):
    """Per node and slot (left, right): box lo/hi (n, 2, 3), index and count (n, 2)."""
    lo = np.stack([tree.nodes["left_lo"], tree.nodes["right_lo"]], axis=1)
    hi = np.stack([tree.nodes["left_hi"], tree.nodes["right_hi"]], axis=1)
    return lo[..., :3], hi[..., :3], lo[..., 3].view(np.int32), hi[..., 3].view(np.int32)


def check_tree(tree, v0, v1, v2, max_leaf_size):
    n = len(v0)
    assert tree.nodes.dtype == layout.BVH_NODE
    assert tree.prim_order.dtype == np.int32
    assert np.array_equal(np.sort(tree.prim_order), np.arange(n))
    assert 1 <= tree.depth < 64

    lo, hi, index, count = child_slots(tree)
    n_nodes = len(tree.nodes)
    empty = (count == 0) & (index == -1)
    interior = (count == 0) & (index >= 0)
    leaf = count > 0
    assert np.all(empty | interior | leaf)
    assert np.all(lo[empty] == np.inf) and np.all(hi[empty] == np.inf)
    if n <= 1 or (n_nodes == 1 and empty.any()):
        # Whole tree in the root: left slot a leaf (or empty when n = 0), right slot empty.
        assert n_nodes == 1 and empty[0, 1] and (leaf[0, 0] if n else empty[0, 0])
    else:
        assert not empty.any()

    # Every node but the root is the child of exactly one slot.
    assert np.array_equal(np.sort(index[interior]), np.arange(1, n_nodes))

    # Leaves tile the primitive array and respect the size limit.
    first, size = index[leaf], count[leaf]
    order = np.argsort(first)
    assert np.array_equal(first[order], np.concatenate([[0], np.cumsum(size[order])[:-1]])[:n])
    assert size.sum() == n and np.all(size <= max_leaf_size)

    # Leaf boxes contain all vertices of their triangles.
    slot = np.repeat(first, size) + ragged_arange(size)
    prims = tree.prim_order[slot]
    box_lo, box_hi = np.repeat(lo[leaf], size, axis=0), np.repeat(hi[leaf], size, axis=0)
    for verts in (v0, v1, v2):
        assert np.all(box_lo <= verts[prims]) and np.all(verts[prims] <= box_hi)

    # Interior boxes contain both boxes of the node they point to.
    child = index[interior]
    assert np.all(lo[interior][:, None] <= lo[child]) and np.all(hi[child] <= hi[interior][:, None])

    assert tree.depth == measured_depth(index, interior)


def measured_depth(index, interior):
    depth, level = 1, np.array([0])
    while True:
        level = index[level][interior[level]]
        if level.size == 0:
            return depth
        depth += 1


def ragged_arange(sizes):
    """Concatenation of arange(s) for every s in sizes."""
    starts = np.cumsum(sizes) - sizes
    return np.arange(sizes.sum()) - np.repeat(starts, sizes)


def traverse(tree, v0, v1, v2, origins, directions):
    """Reference nearest-hit traversal, vectorised over (ray, node) pairs.

    Follows every child whose (slightly padded) box the ray enters, without distance pruning,
    so a triangle missing from a box it belongs to shows up as a lost hit. The slab test takes
    the near plane by direction sign, so an empty box (all corners at +inf) is never entered.
    """
    lo, hi, index, count = child_slots(tree)
    pad = 1e-7 * (1.0 + np.abs(np.concatenate([v0, v1, v2])).max(initial=0.0))
    lo, hi = lo.astype(np.float64) - pad, hi.astype(np.float64) + pad
    with np.errstate(divide="ignore"):
        inv = 1.0 / directions
    n_rays = len(origins)
    best_t = np.full(n_rays, np.inf)
    best_prim = np.full(n_rays, -1, np.int64)
    ray, node = np.arange(n_rays), np.zeros(n_rays, np.int64)
    while ray.size:
        next_ray, next_node = [], []
        for s in (0, 1):
            hit = slab_hit(origins[ray], inv[ray], lo[node, s], hi[node, s])
            r, i, c = ray[hit], index[node[hit], s], count[node[hit], s]
            assert np.all(i >= 0), "entered an empty child"
            leaf = c > 0
            pair_ray = np.repeat(r[leaf], c[leaf])
            prim = tree.prim_order[np.repeat(i[leaf], c[leaf]) + ragged_arange(c[leaf])]
            t = ray_triangle_distance(origins[pair_ray], directions[pair_ray],
                                      v0[prim], v1[prim], v2[prim])
            keep_nearest(best_t, best_prim, pair_ray, t, prim)
            next_ray.append(r[~leaf])
            next_node.append(i[~leaf])
        ray, node = np.concatenate(next_ray), np.concatenate(next_node)
    return best_t, best_prim


def slab_hit(o, inv, lo, hi):
    positive = inv >= 0
    with np.errstate(invalid="ignore"):
        t_near = (np.where(positive, lo, hi) - o) * inv
        t_far = (np.where(positive, hi, lo) - o) * inv
    near, far = np.fmax.reduce(t_near, axis=1), np.fmin.reduce(t_far, axis=1)
    return (near <= far) & (far >= 0) & (near < np.inf)  # entry at +inf is a miss, as in the kernel


def keep_nearest(best_t, best_prim, ray, t, prim):
    """Fold candidate hits into the per-ray best, ties going to the lower triangle index."""
    hit = np.isfinite(t)
    ray, t, prim = ray[hit], t[hit], prim[hit]
    order = np.lexsort((prim, t, ray))
    ray, t, prim = ray[order], t[order], prim[order]
    first = np.concatenate([[True], ray[1:] != ray[:-1]]) if ray.size else np.zeros(0, bool)
    ray, t, prim = ray[first], t[first], prim[first]
    better = (t < best_t[ray]) | ((t == best_t[ray]) & (prim < best_prim[ray]))
    best_t[ray[better]] = t[better]
    best_prim[ray[better]] = prim[better]


def random_rays(v0, v1, v2, n, seed):
    """Rays from around (and inside) the scene box towards random points of the box."""
    rng = np.random.default_rng(seed)
    verts = np.concatenate([v0, v1, v2]) if len(v0) else np.zeros((1, 3))
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    size = np.maximum(hi - lo, 1e-3)
    origins = lo - 0.5 * size + 2.0 * size * rng.random((n, 3))
    targets = lo + size * rng.random((n, 3))
    return origins, targets - origins


def assert_same_hits(tree, v0, v1, v2, n_rays=3000, seed=7):
    origins, directions = random_rays(v0, v1, v2, n_rays, seed)
    t_ref, p_ref = intersect_brute_force(v0, v1, v2, origins, directions)
    t_bvh, p_bvh = traverse(tree, v0, v1, v2, origins, directions)
    assert np.array_equal(np.isinf(t_ref), np.isinf(t_bvh))
    hit = np.isfinite(t_ref)
    np.testing.assert_allclose(t_bvh[hit], t_ref[hit], rtol=1e-5)
    # A different triangle is fine only when it is hit at the same distance (a tie).
    differ = np.flatnonzero(p_bvh != p_ref)
    tie_t = ray_triangle_distance(origins[differ], directions[differ], v0[p_bvh[differ]],
                                  v1[p_bvh[differ]], v2[p_bvh[differ]])
    np.testing.assert_allclose(tie_t, t_ref[differ], rtol=1e-5)
    return np.count_nonzero(hit)


# ---------------------------------------------------------------------------------------------
# Tests


@pytest.mark.parametrize("builder", [build_bvh, ploc.build_ploc_bvh], ids=["binned_sah", "ploc"])
@pytest.mark.parametrize("name", list(SCENES))
@pytest.mark.parametrize("max_leaf_size", [1, 4])
def test_tree_invariants_and_hits(builder, name, max_leaf_size):
    v0, v1, v2 = SCENES[name]()
    tree = builder(v0, v1, v2, max_leaf_size=max_leaf_size)
    check_tree(tree, v0, v1, v2, max_leaf_size)
    n_hits = assert_same_hits(tree, v0, v1, v2)
    if name in ("soup", "plane", "mixed_sizes"):
        assert n_hits > 500  # the comparison is not vacuous


@pytest.mark.parametrize("bins", [2, 5, 32])
def test_bin_counts(bins):
    v0, v1, v2 = soup(1000, 11, size=0.05)
    tree = build_bvh(v0, v1, v2, max_leaf_size=8, bins=bins)
    check_tree(tree, v0, v1, v2, 8)
    assert_same_hits(tree, v0, v1, v2, n_rays=1000)


def test_empty_scene_layout():
    tree = build_bvh(*soup(0, 0))
    assert len(tree.nodes) == 1 and tree.prim_order.size == 0 and tree.depth == 1
    lo, hi, index, count = child_slots(tree)
    assert np.all(index == -1) and np.all(count == 0)


def test_small_scene_is_single_leaf():
    v0, v1, v2 = identical(3)
    tree = build_bvh(v0, v1, v2, max_leaf_size=4)
    lo, hi, index, count = child_slots(tree)
    assert len(tree.nodes) == 1 and tree.depth == 1
    assert (index[0, 0], count[0, 0], index[0, 1], count[0, 1]) == (0, 3, -1, 0)


def test_identical_triangles_split_to_leaf_size():
    v0, v1, v2 = identical(1000)
    tree = build_bvh(v0, v1, v2, max_leaf_size=4)
    check_tree(tree, v0, v1, v2, 4)
    # Index-median splits of 1000 coincident triangles: ceil(log2(1000 / 4)) levels.
    assert tree.depth == 8


def test_depth_limit_forces_median_splits(monkeypatch):
    v0, v1, v2 = exponential_spacing()
    unlimited = build_bvh(v0, v1, v2)
    assert unlimited.depth > 12
    monkeypatch.setattr(bvh_mod, "MAX_DEPTH", 12)
    limited = build_bvh(v0, v1, v2)
    assert limited.depth <= 12
    check_tree(limited, v0, v1, v2, 4)
    assert_same_hits(limited, v0, v1, v2, n_rays=1000)


def test_boxes_contain_float64_vertices_exactly():
    # Coordinates that float32 cannot represent: boxes must still contain them.
    v0, v1, v2 = (v + 1.0 / 3.0 for v in soup(500, 12))
    tree = build_bvh(v0, v1, v2)
    check_tree(tree, v0, v1, v2, 4)


def test_float32_input():
    v0, v1, v2 = (v.astype(np.float32) for v in soup(500, 13))
    tree = build_bvh(v0, v1, v2)
    check_tree(tree, *(v.astype(np.float64) for v in (v0, v1, v2)), 4)


def test_invalid_input():
    v0, v1, v2 = soup(10, 14)
    with pytest.raises(ValueError):
        build_bvh(v0, v1, v2[:5])
    with pytest.raises(ValueError):
        build_bvh(v0[:, :2], v1[:, :2], v2[:, :2])
    v0[3, 1] = np.nan
    with pytest.raises(ValueError):
        build_bvh(v0, v1, v2)
    with pytest.raises(ValueError):
        build_bvh(*soup(10, 14), max_leaf_size=0)


def test_build_is_deterministic():
    v0, v1, v2 = soup(3000, 15)
    a, b = build_bvh(v0, v1, v2), build_bvh(v0, v1, v2)
    assert np.array_equal(a.prim_order, b.prim_order)
    assert a.nodes.tobytes() == b.nodes.tobytes()


# ---------------------------------------------------------------------------------------------
# Brute-force intersector


def unit_triangle():
    return (np.array([[0.0, 0.0, 0.0]]), np.array([[1.0, 0.0, 0.0]]),
            np.array([[0.0, 1.0, 0.0]]))


def test_brute_force_basic_hits():
    v0, v1, v2 = unit_triangle()
    origins = np.array([[0.25, 0.25, 2.0], [0.25, 0.25, -3.0], [0.9, 0.9, 2.0], [0.2, 0.2, 0.0]])
    directions = np.array([[0, 0, -1.0], [0, 0, 1.0], [0, 0, -1.0], [0, 0, 1.0]])
    t, prim = intersect_brute_force(v0, v1, v2, origins, directions)
    assert t.dtype == np.float32 and prim.dtype == np.int32
    # From above, from below (two-sided), outside the triangle, and starting on it (t <= t_min).
    np.testing.assert_allclose(t, [2.0, 3.0, np.inf, np.inf])
    assert prim.tolist() == [0, 0, -1, -1]
    t, prim = intersect_brute_force(v0, v1, v2, origins[:2], directions[:2], t_max=2.5)
    assert t[0] == 2.0 and np.isinf(t[1]) and prim.tolist() == [0, -1]


def test_brute_force_nearest_and_ties():
    v0, v1, v2 = (np.repeat(v, 3, axis=0) for v in unit_triangle())
    shift = np.array([[0, 0, 1.0], [0, 0, -1.0], [0, 0, 1.0]])
    v0, v1, v2 = v0 + shift, v1 + shift, v2 + shift
    t, prim = intersect_brute_force(v0, v1, v2, [[0.2, 0.2, 5.0]], [[0, 0, -1.0]])
    assert t[0] == 4.0 and prim[0] == 0  # triangles 0 and 2 coincide: the lower index wins


def test_brute_force_degenerate_triangle_never_hits():
    p = np.array([[0.0, 0.0, 0.0]])
    t, prim = intersect_brute_force(p, p, p, [[0.0, 0.0, 1.0]], [[0, 0, -1.0]])
    assert np.isinf(t[0]) and prim[0] == -1


def test_brute_force_chunking_is_invisible():
    v0, v1, v2 = soup(700, 16)
    origins, directions = random_rays(v0, v1, v2, 300, 17)
    whole = intersect_brute_force(v0, v1, v2, origins, directions)
    chunked = intersect_brute_force(v0, v1, v2, origins, directions, chunk_elems=1000)
    assert np.array_equal(whole[0], chunked[0]) and np.array_equal(whole[1], chunked[1])
