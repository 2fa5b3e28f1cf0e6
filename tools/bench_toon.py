"""Samples per second of the toon Cornell box against the plain one (same geometry and light).

    python tools/bench_toon.py [--device cpu] [--spp 16] [--runs 3] [--resolution 256]

Prints the median of several timed renders after one warm-up render, and the ratio.
"""
import argparse
import statistics

import clrender


def measure(path, device, spp, runs, resolution):
    scene = clrender.load_scene(path)
    scene.camera.resolution = (resolution, resolution)
    renderer = clrender.Renderer(scene, device)
    renderer.render(spp=1, seed=0)  # warm-up: kernel build and first launch
    rates = [renderer.render(spp=spp, seed=run).samples_per_second for run in range(runs)]
    return statistics.median(rates)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default=None)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--resolution", type=int, default=256)
    args = parser.parse_args()
    rates = {}
    for name in ("cornell_box", "toon_cornell_box"):
        rates[name] = measure(f"scenes/{name}.json", args.device, args.spp, args.runs, args.resolution)
        print(f"{name:18s} {rates[name] / 1e6:8.3f} M samples/s (median of {args.runs}, "
              f"{args.resolution}^2 px, {args.spp} spp)")
    print(f"toon / plain: {rates['toon_cornell_box'] / rates['cornell_box']:.2f}")


if __name__ == "__main__":
    main()
