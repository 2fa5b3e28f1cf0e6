"""Cost of masks (Mitsuba's `mask`) and of their shadow-ray path: the Cornell box as it is (no
TEXTURES feature), with a checkerboard on its white walls (TEXTURES, no mask) and with a masked
panel under its light as well, against another checkout's kernel on the first two (the code
before masks), interleaved round by round so that load on a shared machine hits every variant
alike. Prints median samples/s and the medians of the per-round ratios to the baseline.

    python tools/bench_masks.py [--baseline /path/to/other/checkout] [--rounds 5] [--spp 8]
        [--resolution 96]

Each measurement is a subprocess (the baseline needs its own `import clrender`) that builds or
loads its kernel, warms up with one render and reports the median rate of three (this checkout's
clrender/bench.py, loaded by its path so that the baseline's package stays the one imported).
"""
import argparse
import json
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from clrender.bench import interleaved, median, round_ratios, run_process  # noqa: E402

# The variants of scenes/cornell_box.json: (name, what the worker adds to the scene dict).
VARIANTS = ("plain", "textured", "masked")

WORKER = """
import importlib.util, json, sys
import clrender
bench_path, scene_path, variant, spp, resolution = sys.argv[1:6]
spec = importlib.util.spec_from_file_location("bench", bench_path)
bench = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench)
data = json.load(open(scene_path))
data["camera"]["resolution"] = [int(resolution)] * 2
if variant != "plain":
    data["textures"] = [{"name": "checks", "type": "checkerboard", "color0": 0.8, "color1": 0.5,
                         "to_uv": [[8, 0, 0], [0, 8, 0]]}]
    next(m for m in data["materials"] if m["name"] == "white")["albedo"] = {"texture": "checks"}
if variant == "masked":
    data["materials"].append({"name": "leaf", "type": "diffuse", "albedo": [0.2, 0.6, 0.1],
                              "opacity": {"texture": "checks"}})
    data["shapes"].append({"name": "leaf", "type": "rectangle", "material": "leaf",
                           "transform": {"scale": 0.35, "rotate": [80, 0, 0], "translate": [0, 1.3, 0]}})
renderer = clrender.Renderer(clrender.load_scene_dict(data))
rate = lambda: renderer.render(spp=int(spp), samples_per_pass=int(spp)).samples_per_second
runs = bench.interleaved({"rate": rate}, rounds=3)
print(json.dumps(bench.median(runs["rate"])))
"""


def measure(checkout, variant, spp, resolution):
    """A function running one worker process in `checkout`, returning its samples/s."""
    env = dict(os.environ, PYTHONPATH=str(checkout))
    argv = [sys.executable, "-c", WORKER, str(ROOT / "clrender" / "bench.py"), str(ROOT / "scenes" / "cornell_box.json"),
            variant, str(spp), str(resolution)]
    return lambda: json.loads(run_process(argv, env=env, cwd=checkout).stdout.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--baseline", type=Path, help="another checkout (without masks) to compare with")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--spp", type=int, default=8)
    parser.add_argument("--resolution", type=int, default=96)
    args = parser.parse_args()
    measures = {variant: measure(ROOT, variant, args.spp, args.resolution) for variant in VARIANTS}
    if args.baseline:
        for variant in VARIANTS[:2]:
            measures[f"{variant} (baseline)"] = measure(args.baseline.resolve(), variant, args.spp, args.resolution)
    print(f"{args.rounds} interleaved rounds, {args.spp} spp, {args.resolution}^2; M samples/s are medians")
    rates = interleaved(measures, rounds=args.rounds, warmup=0)
    for name, values in rates.items():
        line = f"{name:22s} {median(values) / 1e6:7.3f}"
        if args.baseline and name in VARIANTS[:2]:
            line += f"  / baseline {median(round_ratios(values, rates[f'{name} (baseline)'])):.3f}"
        if name == "masked":
            line += f"  / textured {median(round_ratios(values, rates['textured'])):.3f}"
        print(line, flush=True)


if __name__ == "__main__":
    main()
