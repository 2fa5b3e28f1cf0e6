"""Samples per second for each example scene: median of several timed renders after a warm-up,
the scenes interleaved (clrender.bench).

    python tools/bench.py [scenes/*.json] [--spp 16] [--runs 5] [--max-depth N] [--device cpu]
"""
import argparse
import glob
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import clrender  # noqa: E402
from clrender.bench import interleaved, median  # noqa: E402


def rate_of(path, device, spp, max_depth=None, rr_depth=None, local_size=None):
    """A function rendering the scene once and returning its samples per second."""
    renderer = clrender.Renderer(clrender.load_scene(path), device, local_size=local_size)
    return lambda: renderer.render(spp=spp, max_depth=max_depth, rr_depth=rr_depth).samples_per_second


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scenes", nargs="*")
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--max-depth", type=int)
    parser.add_argument("--rr-depth", type=int)
    parser.add_argument("--device")
    parser.add_argument("--local-size", type=int, nargs=2)
    args = parser.parse_args()
    scenes = args.scenes or sorted(glob.glob(str(Path(__file__).resolve().parent.parent / "scenes" / "*.json")))
    device = clrender.choose_device(args.device)
    print(f"device: {device.name.strip()}; spp {args.spp}; median of {args.runs} runs")
    local_size = tuple(args.local_size) if args.local_size else None
    rates = interleaved({path: rate_of(path, device, args.spp, args.max_depth, args.rr_depth, local_size)
                         for path in scenes}, rounds=args.runs)
    print(f"{'scene':40s} {'M samples/s':>12s} {'min':>8s} {'max':>8s}")
    for path, values in rates.items():
        print(f"{Path(path).name:40s} {median(values) / 1e6:12.3f} {min(values) / 1e6:8.3f} {max(values) / 1e6:8.3f}")


if __name__ == "__main__":
    main()
