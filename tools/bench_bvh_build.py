"""Benchmark the BVH builds (clrender.ploc.build_ploc_bvh, the scenes' builder, and
clrender.bvh.build_bvh, binned SAH; then wide_bvh.collapse into the kernel's eight-wide tree) on
procedurally generated meshes (no downloads).

Usage: python tools/bench_bvh_build.py [--sizes 100000 1000000] [--repeats 3] [--builders ploc binned]

Meshes: "grid", a displaced height-field grid with exactly the requested triangle count (rounded
to 2*m*m), and "sphere", a trimesh icosphere at the subdivision level nearest to the requested
count. For each mesh and builder, prints the median times of the binary build and of the
collapse over --repeats builds after one warm-up build (interleaved across builders), the total
per million triangles, the node counts, the binary
depth, mean leaf size and the binary tree's SAH cost
(traversal and intersection cost 1, relative to the root box area; lower is better).
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from clrender.bench import interleaved, median, timed  # noqa: E402
from clrender.bvh import build_bvh  # noqa: E402
from clrender.ploc import build_ploc_bvh  # noqa: E402
from clrender.wide_bvh import collapse  # noqa: E402


def displaced_grid(n_triangles):
    """Height field over the unit square: two triangles per grid cell."""
    m = max(1, round(np.sqrt(n_triangles / 2)))
    u, v = np.meshgrid(np.linspace(0, 1, m + 1), np.linspace(0, 1, m + 1), indexing="ij")
    height = 0.05 * np.sin(23 * u) * np.cos(17 * v) + 0.02 * np.sin(71 * (u + v))
    verts = np.stack([u, v, height], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    a = (i * (m + 1) + j).ravel()
    b, c, d = a + (m + 1), a + 1, a + (m + 2)
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([c, b, d], 1)])
    return verts, faces


def icosphere(n_triangles):
    import trimesh

    level = max(0, round(np.log(n_triangles / 20) / np.log(4)))
    mesh = trimesh.creation.icosphere(subdivisions=level)
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


MESHES = {"grid": displaced_grid, "sphere": icosphere}
BUILDERS = {"ploc": build_ploc_bvh, "binned": build_bvh}


def sah_cost(bvh):
    """Expected traversal + intersection cost of a random ray, relative to the root box area."""
    slots = [(bvh.nodes[f"{s}_lo"], bvh.nodes[f"{s}_hi"]) for s in ("left", "right")]
    root_lo = np.minimum(slots[0][0][0, :3], slots[1][0][0, :3])
    root_hi = np.maximum(slots[0][1][0, :3], slots[1][1][0, :3])
    cost = 0.0
    for lo, hi in slots:
        count = hi[:, 3].view(np.int32)
        used = (count > 0) | (lo[:, 3].view(np.int32) >= 0)
        area = half_area(lo[used, :3], hi[used, :3])
        # An interior child costs one node visit, a leaf one intersection per triangle.
        cost += np.sum(area * np.where(count[used] > 0, count[used], 1))
    root_area = half_area(root_lo, root_hi)
    return 1.0 + cost / root_area


def half_area(lo, hi):
    d = (hi - lo).astype(np.float64)
    return d[..., 0] * d[..., 1] + d[..., 1] * d[..., 2] + d[..., 2] * d[..., 0]


def bench(name, n_triangles, repeats, builders):
    verts, faces = MESHES[name](n_triangles)
    v0, v1, v2 = (verts[faces[:, k]] for k in range(3))
    n = len(faces)
    built = {}

    def binary(builder):
        seconds, built[builder] = timed(lambda: BUILDERS[builder](v0, v1, v2))
        return seconds

    def wide(builder):   # the tree the binary build of the same round made
        seconds, (built[builder, "wide"], _) = timed(lambda: collapse(built[builder]))
        return seconds

    # Warm-up: page in code paths and allocator pools.
    measures = {}
    for builder in builders:
        measures[builder, "binary"] = lambda builder=builder: binary(builder)
        measures[builder, "wide"] = lambda builder=builder: wide(builder)
    runs = interleaved(measures, rounds=repeats)
    for builder in builders:
        bvh, wide_nodes = built[builder], built[builder, "wide"]
        median_binary, wide_median = median(runs[builder, "binary"]), median(runs[builder, "wide"])
        n_leaves = sum(int(np.count_nonzero(bvh.nodes[f"{s}_hi"][:, 3].view(np.int32) > 0))
                       for s in ("left", "right"))
        total = median_binary + wide_median
        print(f"{name:7s} {builder:7s} {n:>10,d} {median_binary:9.3f} {wide_median:9.3f} {total / n * 1e6:11.3f} "
              f"{len(bvh.nodes):>10,d} {len(wide_nodes):>10,d} {bvh.depth:6d} {n / max(n_leaves, 1):10.2f} "
              f"{sah_cost(bvh):9.2f}", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    parser.add_argument("--meshes", nargs="+", default=list(MESHES), choices=list(MESHES))
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--builders", nargs="+", default=list(BUILDERS), choices=list(BUILDERS))
    args = parser.parse_args()
    print(f"{'mesh':7s} {'builder':7s} {'triangles':>10s} {'binary s':>9s} {'wide s':>9s} {'total s/Mtri':>11s} "
          f"{'nodes':>10s} {'wide nodes':>10s} {'depth':>6s} {'leaf size':>10s} {'SAH cost':>9s}")
    for name in args.meshes:
        for size in args.sizes:
            bench(name, size, args.repeats, args.builders)


if __name__ == "__main__":
    main()
