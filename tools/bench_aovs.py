"""Cost of the AOVs: colour-only speed (feature AOVS off) against the same render with the
sample-level AOVs on, and optionally against another checkout's colour-only kernel (the code
before the feature existed), interleaved round by round so that load on a shared machine hits
every variant alike. Prints median samples/s and the medians of the per-round ratios.

    python tools/bench_aovs.py [scenes...] [--baseline /path/to/other/checkout] [--rounds 5]
        [--spp 8] [--resolution 96]

Each measurement is a subprocess (the baseline needs its own `import clrender`) that builds or
loads its kernel, warms up with one launch and reports the median rate of three renders.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_SCENES = ["scenes/cornell_box.json", "scenes/cornell_glass.json", "scenes/smoke_cornell_box.json"]

WORKER = """
import json, statistics, sys
import clrender
scene_path, spp, resolution, aovs = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4] == "on"
scene = clrender.load_scene(scene_path)
width, height = scene.camera.resolution
scene.camera.resolution = (resolution, max(1, round(resolution * height / width)))
renderer = clrender.Renderer(scene)
options = {"aovs": ("albedo", "normal", "variance")} if aovs else {}
renderer.render(spp=1, **options)
rates = [renderer.render(spp=spp, samples_per_pass=spp, **options).samples_per_second for _ in range(3)]
print(json.dumps(statistics.median(rates)))
"""


def measure(checkout, scene, spp, resolution, aovs):
    env = dict(os.environ, PYTHONPATH=str(checkout))
    out = subprocess.run([sys.executable, "-c", WORKER, str(ROOT / scene), str(spp), str(resolution),
                          "on" if aovs else "off"], env=env, cwd=checkout, capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scenes", nargs="*", default=DEFAULT_SCENES)
    parser.add_argument("--baseline", type=Path, help="another checkout whose colour-only speed to compare")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--spp", type=int, default=8)
    parser.add_argument("--resolution", type=int, default=96, help="image width (height keeps the aspect)")
    args = parser.parse_args()
    variants = [("off", ROOT, False), ("on", ROOT, True)]
    if args.baseline:
        variants.append(("baseline", args.baseline.resolve(), False))
    print(f"{args.rounds} interleaved rounds, {args.spp} spp, width {args.resolution}; M samples/s are medians")
    header = f"{'scene':28s} " + " ".join(f"{name:>9s}" for name, _, _ in variants)
    header += f" {'on/off':>7s}" + (f" {'off/base':>9s}" if args.baseline else "")
    print(header)
    for scene in args.scenes:
        rates = {name: [] for name, _, _ in variants}
        for _ in range(args.rounds):
            for name, checkout, aovs in variants:
                rates[name].append(measure(checkout, scene, args.spp, args.resolution, aovs))
        ratio = statistics.median(on / off for on, off in zip(rates["on"], rates["off"]))
        line = f"{Path(scene).stem:28s} " + " ".join(f"{statistics.median(r) / 1e6:9.3f}" for r in rates.values())
        line += f" {ratio:7.3f}"
        if args.baseline:
            line += f" {statistics.median(o / b for o, b in zip(rates['off'], rates['baseline'])):9.3f}"
        print(line, flush=True)


if __name__ == "__main__":
    main()
