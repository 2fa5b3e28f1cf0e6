"""Binned-SAH BVH builder in vectorised numpy, and a brute-force ray/triangle reference.

The builder works breadth-first: all nodes of one tree level are split at once, so the number of
Python-level iterations is the tree depth, never the node count. Within a level the active
primitives are kept grouped by node (contiguous segments), which lets per-node reductions use
``reduceat`` and per-(node, bin) reductions use ``bincount`` / ``ufunc.at`` on a combined key.
Partitioning is a stable counting sort computed with prefix sums, so no comparison sort is needed
on the hot path.

Node layout (``layout.BVH_NODE``): each node stores the boxes of both children. ``*_hi.w`` (int
bits) is the child's primitive count (0: interior child), ``*_lo.w`` (int bits) is the child node
index (interior) or the first slot in ``prim_order`` (leaf). An empty child has the box
lo = hi = (+inf, +inf, +inf), count 0 and index -1: the kernel's slab test gives it an entry
distance of +inf (or an exit before the entry) for every ray, so it is never entered.
"""
from dataclasses import dataclass

import numpy as np

from clrender import layout

# The traversal kernel uses a fixed stack of 64 entries.
MAX_DEPTH = 63
TRAVERSAL_COST = 1.0
INTERSECTION_COST = 1.0
# Nearest accepted hit distance, so that a ray leaving a surface does not hit it again.
T_MIN = 1e-6


@dataclass
class Bvh:
    nodes: np.ndarray  # structured array, dtype layout.BVH_NODE; node 0 is the root
    prim_order: np.ndarray  # int32 (N,): prim_order[k] = original triangle index stored at slot k
    depth: int  # nodes on the longest root-to-leaf path (root = 1); leaves live in their parent


@dataclass
class _Children:
    """Child-slot records produced by one level: which parent slot they fill, and with what."""

    parent: np.ndarray  # node index of the parent, -1 for the root task
    side: np.ndarray  # 0: left slot, 1: right slot
    lo: np.ndarray  # (3, K) box
    hi: np.ndarray
    index: np.ndarray  # child node index (interior) or first primitive slot (leaf)
    count: np.ndarray  # 0 for interior children


def build_bvh(v0, v1, v2, max_leaf_size=4, bins=16, spheres=None) -> Bvh:
    """Build a two-child BVH over triangles (v0[i], v1[i], v2[i]) with binned SAH, and over the
    analytic spheres (centres (S, 3), radii (S,)) given as `spheres`: primitive len(v0) + j is
    sphere j.

    Leaves never hold more than ``max_leaf_size`` primitives, and never mix triangles and
    spheres (the kernel tags a leaf with its primitive type). A node whose centroids cannot be
    separated by binning (all coincide) is split at its centroid median instead, and so is a node
    whose SAH split would make the tree deeper than ``MAX_DEPTH``.
    """
    if max_leaf_size < 1 or bins < 2:
        raise ValueError("need max_leaf_size >= 1 and bins >= 2")
    lo, hi, n_triangles = primitive_bounds(v0, v1, v2, spheres)
    n = lo.shape[1]
    if n == 0:
        return Bvh(_empty_nodes(1), np.zeros(0, np.int32), 1)

    prim_order = np.empty(n, np.int32)
    idx = np.arange(n, dtype=np.int32)
    counts = np.array([n], np.int64)
    parent = np.array([-1], np.int32)
    side = np.zeros(1, np.int8)
    records = []
    n_leaf_prims = 0
    n_nodes = 0
    depth = 1
    level = 1
    while counts.size:
        plan = _plan_level(lo, hi, counts, level, max_leaf_size, bins, idx >= n_triangles)
        split = ~plan.leaf
        n_split = int(np.count_nonzero(split))

        index = np.empty(counts.size, np.int64)
        leaf_counts = counts[plan.leaf]
        index[plan.leaf] = n_leaf_prims + _exclusive_cumsum(leaf_counts)
        index[split] = n_nodes + np.arange(n_split)
        records.append(
            _Children(parent, side, plan.box_lo, plan.box_hi, index, np.where(plan.leaf, counts, 0))
        )

        in_leaf = np.flatnonzero(plan.leaf[plan.seg])
        prim_order[n_leaf_prims:n_leaf_prims + in_leaf.size] = idx[in_leaf]
        n_leaf_prims += in_leaf.size

        if n_split:
            depth = level
        perm, counts, child_order = _partition(plan, split, counts, bins)
        lo = np.take(lo, perm, axis=1)
        hi = np.take(hi, perm, axis=1)
        idx = np.take(idx, perm)
        parent = np.repeat(index[split].astype(np.int32), 2)[child_order]
        side = np.tile(np.array([0, 1], np.int8), n_split)[child_order]
        n_nodes += n_split
        level += 1

    assert n_leaf_prims == n
    assert depth < 64, depth
    return Bvh(_assemble_nodes(records, max(n_nodes, 1)), prim_order, depth)


@dataclass
class _LevelPlan:
    seg: np.ndarray  # (n,) node of each active primitive
    starts: np.ndarray  # (K,) first active primitive of each node
    box_lo: np.ndarray  # (3, K) node boxes
    box_hi: np.ndarray
    leaf: np.ndarray  # (K,) bool
    n_left: np.ndarray  # (K,) size of the left child (meaningful for split nodes)
    right: np.ndarray  # (n,) bool, primitive goes to the right child


def _plan_level(lo, hi, counts, level, max_leaf_size, bins, is_sphere) -> _LevelPlan:
    """Decide, for every node of a level at once, whether it is a leaf and how it splits.
    is_sphere: per active primitive; a node holding both kinds must split."""
    k = counts.size
    n = lo.shape[1]
    starts = _exclusive_cumsum(counts)
    seg = np.repeat(np.arange(k, dtype=np.int64), counts)
    spheres = np.add.reduceat(is_sphere.astype(np.int64), starts) if n else np.zeros(k, np.int64)
    mixed = (spheres > 0) & (spheres < counts)

    # Twice the box centre: the factor cancels in every use below.
    cen = lo + hi
    cmin = np.minimum.reduceat(cen, starts, axis=1)
    cmax = np.maximum.reduceat(cen, starts, axis=1)
    axis = np.argmax(cmax - cmin, axis=0)
    nodes = np.arange(k)
    axis_min = cmin[axis, nodes]
    node_bins = _node_bins(counts, bins)
    scale = _bin_scale(cmax[axis, nodes] - axis_min, node_bins)

    c = np.take(cen.ravel(), axis[seg] * n + np.arange(n))
    frac = (c - axis_min[seg]) * scale[seg]  # in [0, node_bins]
    bin_id = np.minimum(frac.astype(np.int64), node_bins[seg] - 1)

    box_lo = np.empty((3, k), np.float32)
    box_hi = np.empty((3, k), np.float32)
    best_plane = np.empty(k, np.int64)
    best_cost = np.empty(k, np.float32)
    n_left = np.empty(k, np.int64)
    for first, last in _runs(node_bins):
        nb = int(node_bins[first])
        e0, e1 = starts[first], starts[last - 1] + counts[last - 1]
        key = bin_id[e0:e1] * (last - first) + (seg[e0:e1] - first)
        bin_counts, bin_lo, bin_hi = _bin_bounds(
            lo[:, e0:e1], hi[:, e0:e1], key, last - first, nb)
        box_lo[:, first:last] = bin_lo.min(axis=0)
        box_hi[:, first:last] = bin_hi.max(axis=0)
        best_plane[first:last], best_cost[first:last], n_left[first:last] = _best_sah_split(
            bin_counts, bin_lo, bin_hi, counts[first:last])

    area = _half_area(box_lo, box_hi)
    has_split = np.isfinite(best_cost)
    split_pays = (TRAVERSAL_COST * area + INTERSECTION_COST * best_cost
                  < INTERSECTION_COST * counts * area)
    # Deeper than MAX_DEPTH a node must be a leaf; the median fallback guarantees it is small.
    leaf = (counts <= max_leaf_size) & ((~(has_split & split_pays) & ~mixed) | (level > MAX_DEPTH))
    if np.any(leaf & mixed):
        raise ValueError(f"BVH deeper than {MAX_DEPTH} levels with triangles and spheres still mixed")

    # Median splits of a mixed node may have to go down to single primitives.
    too_deep = level + _median_depth(np.maximum(n_left, counts - n_left),
                                     np.where(mixed, 1, max_leaf_size)) > MAX_DEPTH
    median = ~leaf & (~has_split | too_deep)
    right = bin_id > best_plane[seg]
    if median.any():
        n_left = np.where(median, counts // 2, n_left)
        _median_sides(right, frac, seg, counts, median, bins)
    return _LevelPlan(seg, starts, box_lo, box_hi, leaf, n_left, right)


def _node_bins(counts, bins):
    """Bins per node: the next power of two >= count, capped at `bins`.

    A node of c primitives fills at most c bins, so small nodes get few bins; this keeps the
    per-bin work proportional to the primitive count instead of bins * nodes. The partition
    orders each level's nodes by this value so that equal-bin nodes form contiguous runs.
    """
    bit_length = np.frexp((np.maximum(counts, 2) - 1).astype(np.float64))[1]
    return np.minimum(np.left_shift(1, bit_length), bins)


def _runs(values):
    """(first, last) index ranges of the runs of equal consecutive values."""
    edges = np.flatnonzero(np.diff(values)) + 1
    bounds = np.concatenate([[0], edges, [len(values)]])
    return zip(bounds[:-1].tolist(), bounds[1:].tolist())


def _bin_scale(extent, bins):
    """Per-node factor mapping a centroid offset to a bin coordinate in [0, bins[node]].

    Zero (or denormal) extents get scale 0, which puts every centroid in bin 0: such a node has
    no binned split and falls back to the median split.
    """
    with np.errstate(divide="ignore", over="ignore"):
        scale = bins.astype(np.float32) / extent
    scale[~np.isfinite(scale)] = 0
    return scale


def _bin_bounds(lo, hi, key, k, bins):
    """Primitive counts (bins, K) and box bounds (bins, 3, K) per bin and node.

    `key` is bin * K + node. Empty bins get inverted boxes. The bin axis comes first so that
    scans over bins work on contiguous (3, K) slices.
    """
    bin_counts = np.bincount(key, minlength=k * bins).reshape(bins, k)
    bin_lo = np.full((3, bins * k), np.inf, np.float32)
    bin_hi = np.full((3, bins * k), -np.inf, np.float32)
    for a in range(3):
        np.minimum.at(bin_lo[a], key, lo[a])
        np.maximum.at(bin_hi[a], key, hi[a])
    return (bin_counts, _bins_first(bin_lo, bins, k), _bins_first(bin_hi, bins, k))


def _bins_first(x, bins, k):
    return np.ascontiguousarray(x.reshape(3, bins, k).transpose(1, 0, 2))


def _best_sah_split(bin_counts, bin_lo, bin_hi, counts):
    """Cheapest plane between bins per node, scored as sum(area * count) of the two sides.

    Plane p puts bins 0..p on the left. Planes leaving one side empty score +inf.
    """
    left_lo = _scan(np.minimum, bin_lo)[:-1]
    left_hi = _scan(np.maximum, bin_hi)[:-1]
    right_lo = _scan(np.minimum, bin_lo, reverse=True)[1:]
    right_hi = _scan(np.maximum, bin_hi, reverse=True)[1:]
    n_left = _scan(np.add, bin_counts)[:-1]
    n_right = counts - n_left
    with np.errstate(invalid="ignore", over="ignore"):
        cost = _half_area(left_lo, left_hi) * n_left + _half_area(right_lo, right_hi) * n_right
    cost[(n_left == 0) | (n_right == 0)] = np.inf
    best_plane = np.argmin(cost, axis=0)
    nodes = np.arange(counts.size)
    return best_plane, cost[best_plane, nodes], n_left[best_plane, nodes]


def _scan(op, x, reverse=False):
    """Inclusive scan along axis 0; a loop over the few bins beats ufunc.accumulate by ~10x."""
    out = x.copy()
    steps = range(len(x) - 2, -1, -1) if reverse else range(1, len(x))
    for b in steps:
        prev = b + 1 if reverse else b - 1
        op(out[prev], out[b], out=out[b])
    return out


def _half_area(lo, hi):
    """Half the surface area of boxes with xyz on axis -2; relative SAH needs no factor 2.

    float32 suffices to rank split candidates; inverted (empty) boxes come out as +inf.
    """
    d = hi - lo
    dx, dy, dz = d[..., 0, :], d[..., 1, :], d[..., 2, :]
    return dx * dy + dy * dz + dz * dx


def _median_depth(counts, max_leaf_size):
    """Depth of the subtree that median splits build over `counts` primitives (0 for a leaf).

    Median splitting needs the smallest h with count <= max_leaf_size * 2**h; that is the bit
    length of ceil(count / max_leaf_size) - 1, and frexp's exponent is that bit length.
    """
    chunks = -(-counts // max_leaf_size)
    return np.frexp((chunks - 1).astype(np.float64))[1]


def _median_sides(right, frac, seg, counts, median, bins):
    """Overwrite `right` for median-split nodes: the upper half of centroids goes right.

    One float64 key, node * (bins + 1) + frac, orders each node's primitives by centroid (frac
    lies in [0, bins] up to rounding). Ties keep their current order, so coincident centroids
    split at the index median.
    """
    members = np.flatnonzero(median[seg])
    key = seg[members] * (bins + 1.0) + frac[members]
    ordered = members[np.argsort(key, kind="stable")]
    node = seg[ordered]
    sub_start = np.zeros(counts.size, np.int64)
    sub_start[median] = _exclusive_cumsum(counts[median])
    rank = np.arange(members.size) - sub_start[node]
    right[ordered] = rank >= counts[node] // 2


def _partition(plan, split, counts, bins):
    """Stable partition of the primitives of split nodes into (left, right) child segments.

    Children are listed in parent order, left before right, then stably reordered by their bin
    count (see _node_bins). Returns the gather permutation for the next level's arrays, the
    children's sizes and that reordering (indices into the parent-ordered child list).
    Primitives of leaves are dropped.
    """
    n_left = plan.n_left[split]
    natural_counts = np.stack([n_left, counts[split] - n_left], axis=1).ravel()
    order = np.argsort(_node_bins(natural_counts, bins).astype(np.uint16), kind="stable")
    position = np.empty_like(order)
    position[order] = np.arange(order.size)
    child_counts = natural_counts[order]
    child_starts = _exclusive_cumsum(child_counts)

    split_rank = np.cumsum(split) - 1
    kept = np.flatnonzero(split[plan.seg])
    seg = plan.seg[kept]
    right = plan.right[kept]
    # Position of each primitive among the same-side primitives of its node.
    lefts_before = _exclusive_cumsum(~plan.right)
    node_start = plan.starts[seg]
    left_rank = lefts_before[kept] - lefts_before[node_start]
    rank = np.where(right, kept - node_start - left_rank, left_rank)
    dest = child_starts[position[2 * split_rank[seg] + right]] + rank

    perm = np.empty(kept.size, np.int64)
    perm[dest] = kept
    return perm, child_counts, order


def _exclusive_cumsum(x):
    out = np.zeros(len(x), np.int64)
    np.cumsum(x[:-1], out=out[1:])
    return out


def primitive_bounds(v0, v1, v2, spheres=None):
    """(lo, hi, number of triangles): the boxes (3, N) float32 of the triangles, then of the
    spheres (centres, radii) if given, numbered as build_bvh numbers primitives."""
    lo, hi = _triangle_bounds(v0, v1, v2)
    n_triangles = lo.shape[1]
    if spheres is not None and len(spheres[1]):
        sphere_lo, sphere_hi = sphere_bounds(*spheres)
        lo, hi = np.concatenate([lo, sphere_lo], axis=1), np.concatenate([hi, sphere_hi], axis=1)
    return lo, hi, n_triangles


def _triangle_bounds(v0, v1, v2):
    """Per-triangle boxes as (3, N) float32 that contain the input corners exactly: of float32
    corners their exact bounds, of others the float64 bounds rounded outwards."""
    v0, v1, v2 = (np.asarray(v) for v in (v0, v1, v2))
    exact = all(v.dtype == np.float32 for v in (v0, v1, v2))
    if not exact:
        v0, v1, v2 = (v.astype(np.float64) for v in (v0, v1, v2))
    if not (v0.ndim == 2 and v0.shape[1] == 3 and v0.shape == v1.shape == v2.shape):
        raise ValueError("v0, v1, v2 must be (N, 3) arrays of the same shape")
    lo = np.minimum(np.minimum(v0, v1), v2).T
    hi = np.maximum(np.maximum(v0, v1), v2).T
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
        raise ValueError("triangle vertices must be finite")
    if exact:
        return np.ascontiguousarray(lo), np.ascontiguousarray(hi)
    return _round_down(lo), -_round_down(-hi)


def sphere_bounds(centres, radii):
    """Boxes (3, S) float32 of spheres, rounded outwards so that they contain the spheres as the
    kernel sees them (float32 centre and radius)."""
    centres = np.asarray(centres, np.float32).astype(np.float64).reshape(-1, 3)
    radii = np.abs(np.asarray(radii, np.float32).astype(np.float64)).reshape(-1, 1)
    if not (np.isfinite(centres).all() and np.isfinite(radii).all()):
        raise ValueError("sphere centres and radii must be finite")
    return _round_down((centres - radii).T), -_round_down(-(centres + radii).T)


def _round_down(x64):
    """float32 conversion rounded towards -inf.

    Steps one ulp down through the integer bits where rounding went up (faster than
    np.nextafter). A positive float moves down by bits - 1, a negative one (sign bit set, so a
    negative int32) by bits + 1; rounding never goes up to +0.0, so that NaN case cannot occur.
    """
    x = np.ascontiguousarray(x64, np.float32)
    bits = x.view(np.int32)
    step = np.where(bits < 0, np.int32(1), np.int32(-1))
    bits += step * (x > x64)
    return x


_SLOTS = (("left_lo", "left_hi"), ("right_lo", "right_hi"))


def _empty_nodes(n):
    nodes = np.zeros(n, layout.BVH_NODE)
    for lo_name, hi_name in _SLOTS:
        nodes[lo_name][:, :3] = np.inf
        nodes[hi_name][:, :3] = np.inf
        nodes[lo_name].view(np.int32)[:, 3] = -1
        nodes[hi_name].view(np.int32)[:, 3] = 0
    return nodes


def _assemble_nodes(records, n_nodes):
    """Write every level's child records into the node array.

    The root task has no parent: when it is a leaf it becomes the root's left child; when it is
    interior it is node 0 itself and its record is dropped.
    """
    rec = _Children(*(np.concatenate([getattr(r, f) for r in records], axis=-1)
                      for f in ("parent", "side", "lo", "hi", "index", "count")))
    root_leaf = (rec.parent < 0) & (rec.count > 0)
    rec.parent[root_leaf] = 0
    nodes = _empty_nodes(n_nodes)
    for s, (lo_name, hi_name) in enumerate(_SLOTS):
        sel = (rec.parent >= 0) & (rec.side == s)
        at = rec.parent[sel]
        nodes[lo_name][at, :3] = rec.lo[:, sel].T
        nodes[hi_name][at, :3] = rec.hi[:, sel].T
        nodes[lo_name].view(np.int32)[at, 3] = rec.index[sel]
        nodes[hi_name].view(np.int32)[at, 3] = rec.count[sel]
    return nodes


def ray_triangle_distance(origins, directions, v0, v1, v2, t_min=T_MIN):
    """Two-sided Moller-Trumbore in float64 on broadcastable (..., 3) arrays.

    Returns the hit distance, +inf where the ray misses or the hit is not beyond t_min.
    Degenerate triangles (zero determinant) never hit.
    """
    o, d, a, b, c = (np.asarray(x, np.float64) for x in (origins, directions, v0, v1, v2))
    e1 = b - a
    e2 = c - a
    p = _cross(d, e2)
    det = _dot(e1, p)
    s = o - a
    q = _cross(s, e1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inv = 1.0 / det
        u = _dot(s, p) * inv
        v = _dot(d, q) * inv
        t = _dot(e2, q) * inv
        hit = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > t_min)
    return np.where(hit, t, np.inf)


def _cross(a, b):
    x = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    y = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    z = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return np.stack([x, y, z], axis=-1)


def _dot(a, b):
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def ray_sphere_distance(origins, directions, centres, radii, t_min=T_MIN):
    """Nearest ray/sphere distance beyond t_min in float64 on broadcastable (..., 3) origins,
    directions and centres and (...) radii; +inf where the ray misses."""
    o, d, c = (np.asarray(x, np.float64) for x in (origins, directions, centres))
    r = np.abs(np.asarray(radii, np.float64))
    f = o - c
    a = _dot(d, d)
    b = _dot(f, d)
    disc = b * b - a * (_dot(f, f) - r * r)
    with np.errstate(invalid="ignore", divide="ignore"):
        root = np.sqrt(disc)
        near, far = (-b - root) / a, (-b + root) / a
    t = np.where(near > t_min, near, np.where(far > t_min, far, np.inf))
    return np.where(disc >= 0, t, np.inf)


def intersect_brute_force(v0, v1, v2, origins, directions, t_max=np.inf, chunk_elems=1 << 21, spheres=None):
    """Nearest hit of every ray against every triangle, and every sphere of `spheres`
    ((centres (S, 3), radii (S,)), numbered after the triangles as in build_bvh): the reference
    for tests.

    Returns (hit_t float32 (R,), prim int32 (R,)); misses have t = inf and prim = -1. Only hits
    with T_MIN < t < t_max count; among equal distances the lowest index wins. Primitives are
    processed in chunks so that at most ~chunk_elems ray/primitive pairs are live.
    """
    t, prim = _intersect_triangles_brute_force(v0, v1, v2, origins, directions, t_max, chunk_elems)
    if spheres is None or not len(spheres[1]):
        return t, prim
    o = np.asarray(origins, np.float64).reshape(-1, 1, 3)
    d = np.asarray(directions, np.float64).reshape(-1, 1, 3)
    centres, radii = (np.asarray(x, np.float64) for x in spheres)
    sphere_t = ray_sphere_distance(o, d, centres.reshape(1, -1, 3), radii.reshape(1, -1))
    sphere_t[sphere_t >= t_max] = np.inf
    nearest = np.argmin(sphere_t, axis=1)
    nearest_t = sphere_t[np.arange(len(o)), nearest]
    closer = nearest_t < t
    t[closer] = nearest_t[closer]
    prim[closer] = len(np.asarray(v0).reshape(-1, 3)) + nearest[closer]
    return t, prim


def _intersect_triangles_brute_force(v0, v1, v2, origins, directions, t_max, chunk_elems):
    v0, v1, v2 = (np.asarray(v, np.float64).reshape(-1, 3) for v in (v0, v1, v2))
    o = np.asarray(origins, np.float64).reshape(-1, 1, 3)
    d = np.asarray(directions, np.float64).reshape(-1, 1, 3)
    n_rays = o.shape[0]
    best_t = np.full(n_rays, np.inf)
    best_prim = np.full(n_rays, -1, np.int32)
    if n_rays == 0:
        return best_t.astype(np.float32), best_prim
    rays = np.arange(n_rays)
    step = max(1, chunk_elems // n_rays)
    for first in range(0, v0.shape[0], step):
        chunk = slice(first, first + step)
        t = ray_triangle_distance(o, d, v0[None, chunk], v1[None, chunk], v2[None, chunk])
        t[t >= t_max] = np.inf
        nearest = np.argmin(t, axis=1)
        t_near = t[rays, nearest]
        closer = t_near < best_t
        best_t[closer] = t_near[closer]
        best_prim[closer] = first + nearest[closer]
    return best_t.astype(np.float32), best_prim
