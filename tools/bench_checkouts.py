"""Kernel speed of two checkouts of clrender, A against B (a branch against main): fresh processes
alternating between the checkouts round by round, each rendering every scene with the megakernel
and, where the packets cover it, with packets (Renderer(packets=...)), after a 1-spp warm-up,
the median samples per CPU second of --renders renders (CPU seconds of the process: PoCL's
threads run in it; less sensitive than wall time to other work on the machine); the ratio B / A
per round (same load), and its median over the rounds.

    python3 tools/bench_checkouts.py /work/main . [--scenes scenes/cornell_box.json ...]
                                     [--rounds 5] [--renders 3] [--spp 16] [--packets-only]

Each process imports clrender from its checkout (PYTHONPATH) and runs there, with the scenes'
absolute paths; kernel caches are warm after the first round.
"""
import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

DEFAULT_SCENES = ("scenes/cornell_box.json", "scenes/cornell_glass.json", "scenes/tir_prism.json",
                  "scenes/rough_glass.json")

# What one process runs, in its checkout: name -> samples per second, printed as JSON.
CHILD = """
import json, os, statistics, sys
import clrender
spp, renders, kernels, scenes = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3], sys.argv[4:]

def samples_per_cpu_second(renderer, seed):
    before = os.times()
    image = renderer.render(spp=spp, seed=seed).image
    after = os.times()
    return image.shape[0] * image.shape[1] * spp / (after.user - before.user + after.system - before.system)

rates = {}
for path in scenes:
    for packets in {"both": (False, True), "packets": (True,)}[kernels]:
        renderer = clrender.Renderer(clrender.load_scene(path), packets=packets)
        if packets and renderer.features["LANES"] == 1:
            continue
        renderer.render(spp=1, seed=0)
        name = f"{path} {'packets' if packets else 'megakernel'}"
        rates[name] = statistics.median(samples_per_cpu_second(renderer, s) for s in range(renders))
print(json.dumps(rates))
"""


def run(checkout, scenes, spp, renders, kernels):
    env = dict(os.environ, PYTHONPATH=str(checkout))
    done = subprocess.run([sys.executable, "-c", CHILD, str(spp), str(renders), kernels, *scenes], cwd=checkout, env=env,
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{checkout}: {done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def short_names(paths):
    """Each path's shortest tail of folders that no other path ends with (mirrored scenes share
    file names: .../real-mitsuba-cbox-256x256/independent/cbox.xml), else the whole path."""
    for depth in range(1, max(len(Path(p).parts) for p in paths)):
        names = {p: "/".join(Path(p).parts[-depth:]) for p in paths}
        if len(set(names.values())) == len(paths):
            return names
    return {p: p for p in paths}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("a", type=Path)
    parser.add_argument("b", type=Path)
    parser.add_argument("--scenes", nargs="+", default=list(DEFAULT_SCENES))
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--renders", type=int, default=3)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--packets-only", action="store_true", help="skip the megakernel's renders")
    args = parser.parse_args()
    a, b = args.a.resolve(), args.b.resolve()
    scenes = [str(Path(s).resolve()) for s in args.scenes]
    kernels = "packets" if args.packets_only else "both"
    run(a, scenes, args.spp, 1, kernels), run(b, scenes, args.spp, 1, kernels)   # kernel builds into the caches
    names = short_names(scenes)
    ratios = {}
    for number in range(args.rounds):
        order = (a, b) if number % 2 == 0 else (b, a)
        rates = {checkout: run(checkout, scenes, args.spp, args.renders, kernels) for checkout in order}
        for key in rates[a]:
            path, kernel = key.rsplit(" ", 1)
            ratios.setdefault(f"{names[path]} {kernel}", []).append(rates[b][key] / rates[a][key])
        print(f"round {number + 1}: " + ", ".join(f"{name} {ratios[name][-1]:.3f}" for name in ratios), flush=True)
    print(f"\nsamples per CPU second, {b} / {a}: median of {args.rounds} rounds (min-max)")
    for name, values in ratios.items():
        values = sorted(values)
        print(f"{name:40s} x{values[len(values) // 2]:.3f} ({values[0]:.3f}-{values[-1]:.3f})")


if __name__ == "__main__":
    main()
