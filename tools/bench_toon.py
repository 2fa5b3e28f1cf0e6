"""Samples per second of the toon Cornell box against the plain one (same geometry and light).

    python tools/bench_toon.py [--device cpu] [--spp 16] [--runs 3] [--resolution 256]

Prints the median of several timed renders after one warm-up render (interleaved,
clrender.bench), and the ratio.
"""
import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import clrender  # noqa: E402
from clrender.bench import interleaved, median  # noqa: E402


def rate_of(path, device, spp, resolution):
    scene = clrender.load_scene(path)
    scene.camera.resolution = (resolution, resolution)
    renderer = clrender.Renderer(scene, device)
    seeds = iter(range(1, 1 << 30))
    return lambda: renderer.render(spp=spp, seed=next(seeds)).samples_per_second


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default=None)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--resolution", type=int, default=256)
    args = parser.parse_args()
    root = Path(__file__).resolve().parent.parent / "scenes"
    runs = interleaved({name: rate_of(root / f"{name}.json", args.device, args.spp, args.resolution)
                        for name in ("cornell_box", "toon_cornell_box")}, rounds=args.runs)
    rates = {name: median(values) for name, values in runs.items()}
    for name, rate in rates.items():
        print(f"{name:18s} {rate / 1e6:8.3f} M samples/s (median of {args.runs}, "
              f"{args.resolution}^2 px, {args.spp} spp)")
    print(f"toon / plain: {rates['toon_cornell_box'] / rates['cornell_box']:.2f}")


if __name__ == "__main__":
    main()
