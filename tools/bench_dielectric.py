"""Cost of the DIELECTRIC kernel feature on samples per second.

Usage: python tools/bench_dielectric.py [--seconds 3] [--repeats 3] [--resolution 256] [--max-depth N]

Renders, on the chosen device (default: $CLRENDER_DEVICE, else a GPU, else the CPU):
  cornell_box.json    with the kernel the scene needs (DIELECTRIC=0) and with DIELECTRIC=1 forced:
                      the cost of compiling the feature in, with no glass in view;
  cornell_glass.json  with its sphere made of the walls' diffuse white (DIELECTRIC=0): the same
                      triangles, to separate the cost of the sphere's geometry from its glass;
  cornell_glass.json  (DIELECTRIC=1): a smooth glass sphere in place of the short block;
  rough_glass.json    (DIELECTRIC=1): a rough glass sphere and a rough metal block.
Each configuration is warmed up, then rendered --repeats times (interleaved, so that load from
other processes spreads over all of them) for about --seconds each; prints the median samples per
second and its ratio to the Cornell box without the feature. Samples are camera samples (pixels x
spp), whatever their path length: glass makes paths longer, which is part of its cost. The glass
scenes allow 16 vertices per path and the Cornell box 8; --max-depth sets one depth for all.
"""
import argparse
import os
import sys

import pyopencl as cl

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import clrender  # noqa: E402
from clrender.device import build_program  # noqa: E402
from clrender.bench import interleaved, median, timed  # noqa: E402
from clrender.energy import fill_albedo_tables  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def renderer_for(scene_file, resolution, device, force=None, diffuse_sphere=False, max_depth=None):
    scene = clrender.load_scene(os.path.join(ROOT, "scenes", scene_file))
    scene.camera.resolution = (resolution, resolution)
    if diffuse_sphere:
        white = [m.name for m in scene.materials].index("white")
        for shape in scene.shapes:
            if scene.materials[shape.material].type == "dielectric":
                shape.material = white
    renderer = clrender.Renderer(scene, device)
    if force:
        renderer.features = {**renderer.features, **force}
        program = build_program(renderer.context, renderer.features)
        renderer.kernel = cl.Kernel(program, "render_pass")
        fill_albedo_tables(renderer.queue, renderer.arrays)
    if max_depth:
        renderer.scene.render.max_depth = max_depth
    return renderer


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--device", default=None)
    parser.add_argument("--max-depth", type=int, default=None, help="override every scene's max depth")
    args = parser.parse_args()
    device = clrender.choose_device(args.device)
    configs = [
        ("cornell_box, DIELECTRIC=0", "cornell_box.json", None, False),
        ("cornell_box, DIELECTRIC=1", "cornell_box.json", {"DIELECTRIC": 1}, False),
        ("cornell_glass diffuse sphere", "cornell_glass.json", None, True),
        ("cornell_glass, DIELECTRIC=1", "cornell_glass.json", None, False),
        ("rough_glass, DIELECTRIC=1", "rough_glass.json", None, False),
    ]
    print(f"device: {device.name}; {args.resolution}x{args.resolution}, ~{args.seconds} s per run, "
          f"median of {args.repeats}")
    measures = {}
    for name, scene_file, force, diffuse_sphere in configs:
        setup, renderer = timed(lambda: renderer_for(scene_file, args.resolution, device, force, diffuse_sphere,
                                                     args.max_depth))
        first_launch, _ = timed(lambda: renderer.render(spp=2, seed=0))
        warm = renderer.render(spp=2, seed=0)
        spp = max(1, round(args.seconds * warm.samples_per_second / args.resolution ** 2))
        measures[name] = _rate(renderer, spp)
        print(f"  {name}: features {renderer.features}, max depth {renderer.scene.render.max_depth}, "
              f"set-up and first launch {setup + first_launch:.2f} s, {spp} spp per run")
    runs = interleaved(measures, rounds=args.repeats, warmup=0)   # warmed up above
    base = median(runs[configs[0][0]])
    print(f"{'configuration':32s} {'Msamples/s':>11s} {'ratio':>7s}   runs (Msamples/s)")
    for name, rates in runs.items():
        print(f"{name:32s} {median(rates) / 1e6:11.3f} {median(rates) / base:7.3f}   "
              + " ".join(f"{r / 1e6:.3f}" for r in rates))


def _rate(renderer, spp):
    seeds = iter(range(1, 1 << 30))

    def rate():
        result = renderer.render(spp=spp, seed=next(seeds))
        assert result.discarded_samples == 0
        return result.samples_per_second
    return rate


if __name__ == "__main__":
    main()
