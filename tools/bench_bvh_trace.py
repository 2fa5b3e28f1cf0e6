"""BVH traversal speed on the device: rays/s for camera rays (one ray per sample) against a
large procedural mesh, median of several renders after a warm-up.

    python tools/bench_bvh_trace.py [--triangles 1000000] [--resolution 512] [--device cpu]
"""
import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import trimesh  # noqa: E402

import clrender  # noqa: E402
from bench_bvh_build import displaced_grid  # noqa: E402
from clrender.bench import interleaved, median, timed  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--triangles", type=int, default=1_000_000)
    parser.add_argument("--resolution", type=int, default=512)
    parser.add_argument("--spp", type=int, default=8)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--device")
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
        setup, renderer = timed(lambda: clrender.Renderer(scene, args.device))
    print(f"device: {renderer.device.name.strip()}")
    print(f"mesh: {len(renderer.arrays.triangles)} triangles, BVH {len(renderer.arrays.nodes)} nodes, "
          f"depth {renderer.arrays.bvh_depth}; scene set-up (load, build, upload, kernel) {setup:.2f} s")
    labels = {1: "camera rays only", 2: "camera + shadow + bounce rays"}
    runs = interleaved({depth: (lambda depth=depth: renderer.render(spp=args.spp, max_depth=depth).samples_per_second)
                        for depth in labels}, rounds=args.runs)
    for depth, rates in runs.items():
        print(f"max depth {depth} ({labels[depth]}): {median(rates) / 1e6:.2f} M samples/s "
              f"(median of {args.runs}; min {min(rates) / 1e6:.2f}, max {max(rates) / 1e6:.2f})")
    print("at max depth 1 each sample is one closest-hit ray: M samples/s = M rays/s")


if __name__ == "__main__":
    main()
