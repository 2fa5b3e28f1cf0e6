"""BVH traversal speed on the device: rays/s for camera rays (one ray per sample) against a
large procedural mesh, median of several renders after a warm-up.

    python tools/bench_bvh_trace.py [--triangles 1000000] [--resolution 512] [--device cpu]
                                    [--builders ploc binned]

--builders: the binary trees to trace (collapsed to the kernel's wide tree alike): ploc, the
scenes' builder (clrender/ploc.py), and binned, the top-down binned SAH of clrender/bvh.py
(put in the scene arrays' place for the comparison); interleaved, with per-round ratios.
"""
import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import trimesh  # noqa: E402

import clrender  # noqa: E402
import clrender.arrays  # noqa: E402
from bench_bvh_build import displaced_grid  # noqa: E402
from clrender.bench import interleaved, median, round_ratios, timed  # noqa: E402
from clrender.bvh import build_bvh  # noqa: E402
from clrender.ploc import build_ploc_bvh  # noqa: E402

BUILDERS = {"ploc": build_ploc_bvh, "binned": build_bvh}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--triangles", type=int, default=1_000_000)
    parser.add_argument("--resolution", type=int, default=512)
    parser.add_argument("--spp", type=int, default=8)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--device")
    parser.add_argument("--builders", nargs="+", default=["ploc"], choices=list(BUILDERS))
    args = parser.parse_args()
    vertices, faces = displaced_grid(args.triangles)
    with tempfile.TemporaryDirectory() as folder:
        trimesh.Trimesh(vertices * 4 - [2, 2, 0], faces, process=False).export(Path(folder) / "grid.ply")
        scene = clrender.load_scene_dict({
            "camera": {"position": [0.3, -2.5, 1.6], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov": 55,
                       "resolution": [args.resolution, args.resolution]},
            "materials": [{"name": "m", "type": "diffuse", "albedo": [0.5, 0.5, 0.5]}],
            "shapes": [{"type": "mesh", "file": "grid.ply", "material": "m"}],
            "lights": [{"type": "environment", "radiance": 1.0}],
        }, base_dir=folder)
        renderers = {}
        for builder in args.builders:
            clrender.arrays.build_ploc_bvh = BUILDERS[builder]
            setup, renderers[builder] = timed(lambda: clrender.Renderer(scene, args.device))
            arrays = renderers[builder].arrays
            print(f"{builder}: {len(arrays.info)} triangles, BVH {len(arrays.nodes)} wide nodes, "
                  f"depth {arrays.bvh_depth}; scene set-up (build, upload, kernel) {setup:.2f} s")
        clrender.arrays.build_ploc_bvh = build_ploc_bvh
    print(f"device: {renderers[args.builders[0]].device.name.strip()}")
    labels = {1: "camera rays only", 2: "camera + shadow + bounce rays"}
    runs = interleaved({(builder, depth): (lambda r=renderer, depth=depth:
                                           r.render(spp=args.spp, max_depth=depth).samples_per_second)
                        for builder, renderer in renderers.items() for depth in labels}, rounds=args.runs)
    for (builder, depth), rates in runs.items():
        print(f"{builder}, max depth {depth} ({labels[depth]}): {median(rates) / 1e6:.2f} M samples/s "
              f"(median of {args.runs}; min {min(rates) / 1e6:.2f}, max {max(rates) / 1e6:.2f})")
        if builder != args.builders[0]:
            ratio = median(round_ratios(rates, runs[args.builders[0], depth]))
            print(f"  {builder} / {args.builders[0]}: {ratio:.3f} (median of per-round ratios)")
    print("at max depth 1 each sample is one closest-hit ray: M samples/s = M rays/s")


if __name__ == "__main__":
    main()
