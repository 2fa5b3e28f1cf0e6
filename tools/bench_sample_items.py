"""Sample items (clrender/sample_items.py: one work-item per pixel and sample) against one
work-item per pixel, on the megakernel of one device: wall seconds of the same renders,
alternating in one process (median of the rounds' ratios), and whether the images are the same
bits.

    python tools/bench_sample_items.py [SCENE.json ...] [--real-scenes ../shared/real-scenes]
        [--size 128] [--spp 64] [--runs 5] [--device gpu] [--launches]

Real scenes are sized as tools/peers.py sizes them (the longer side --size, the 48 x 48 test
scenes at their own size); JSON scenes at their own resolution. --launches also prints, per scene
and mode, the samples and seconds of each launch of one more render.
"""
import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import clrender  # noqa: E402
import real_scenes  # noqa: E402
from clrender.bench import interleaved, median, round_ratios, timed  # noqa: E402


def scenes(args):
    """name -> Scene of the scenes asked for."""
    found = real_scenes.sized_scenes(args.real_scenes, args.size) if args.real_scenes else {}
    found.update({Path(path).stem: clrender.load_scene(path) for path in args.scenes})
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scenes", nargs="*")
    parser.add_argument("--real-scenes", nargs="+", type=Path)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--device", default=None)
    parser.add_argument("--launches", action="store_true", help="the launches of one more render, one by one")
    args = parser.parse_args()
    configs = {"per pixel": False, "sample items": True}
    header = ["scene (size)"] + [f"{name} s" for name in configs] + [f"speed-up {name}" for name in configs
                                                                     if name != "per pixel"] + ["same bits"]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for name, scene in scenes(args).items():
        renderers = {config: clrender.Renderer(scene, args.device, packets=False, sample_items=choice)
                     for config, choice in configs.items()}
        results = interleaved({config: lambda r=r: timed(lambda: r.render(spp=args.spp, seed=1).image)
                               for config, r in renderers.items()}, args.runs)
        seconds = {config: [s for s, _ in values] for config, values in results.items()}
        images = [values[-1][1] for values in results.values()]
        same = all(np.array_equal(images[0], image) for image in images[1:])
        width, height = scene.camera.resolution
        cells = [f"{name} ({width}x{height})"] + [f"{median(seconds[c]):.4g}" for c in configs]
        cells += [f"{median(round_ratios(seconds['per pixel'], seconds[c])):.2f}" for c in configs if c != "per pixel"]
        print("| " + " | ".join(cells + ["yes" if same else "no"]) + " |", flush=True)
        if args.launches:
            for config, renderer in renderers.items():
                print(f"  {name}, {config}: launches (samples per pixel, seconds) "
                      f"{launches(renderer, args.spp)}", flush=True)


def launches(renderer, spp):
    """(samples per pixel, kernel seconds) of each launch of one render of `spp` samples."""
    done = []
    renderer.render(spp=spp, seed=1, progress=lambda samples, _end, seconds: done.append((samples, seconds)))
    steps, previous = [], (0, 0.0)
    for samples, seconds in done:
        steps.append((round(samples - previous[0], 3), round(seconds - previous[1], 5)))
        previous = (samples, seconds)
    return steps


if __name__ == "__main__":
    main()
