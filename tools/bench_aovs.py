"""Cost of the AOVs: colour-only speed (feature AOVS off) against the same render with the
sample-level AOVs on, and optionally against another checkout's colour-only kernel (the code
before the feature existed), interleaved round by round so that load on a shared machine hits
every variant alike. Prints median samples/s and the medians of the per-round ratios.

    python tools/bench_aovs.py [scenes...] [--baseline /path/to/other/checkout] [--rounds 5]
        [--spp 8] [--resolution 96]

Each measurement is a subprocess (the baseline needs its own `import clrender`) that builds or
loads its kernel, warms up with one render and reports the median rate of three (this checkout's
clrender/bench.py, loaded by its path so that the baseline's package stays the one imported).
"""
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from clrender.bench import checkout_comparison_arguments, checkout_worker, interleaved, median, round_ratios  # noqa: E402

DEFAULT_SCENES = ["scenes/cornell_box.json", "scenes/cornell_glass.json", "scenes/smoke_cornell_box.json"]

WORKER = """
import importlib.util, json, sys
import clrender
bench_path, scene_path, spp, resolution, aovs = sys.argv[1:6]
spec = importlib.util.spec_from_file_location("bench", bench_path)
bench = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench)
scene = clrender.load_scene(scene_path)
width, height = scene.camera.resolution
resolution, spp = int(resolution), int(spp)
scene.camera.resolution = (resolution, max(1, round(resolution * height / width)))
renderer = clrender.Renderer(scene)
options = {"aovs": ("albedo", "normal", "variance")} if aovs == "on" else {}
rate = lambda: renderer.render(spp=spp, samples_per_pass=spp, **options).samples_per_second
runs = bench.interleaved({"rate": rate}, rounds=3)
print(json.dumps(bench.median(runs["rate"])))
"""


def measure(checkout, scene, spp, resolution, aovs):
    """A function running one worker process in `checkout`, returning its samples/s."""
    return checkout_worker(checkout, WORKER, ROOT / "clrender" / "bench.py", ROOT / scene, spp, resolution,
                           "on" if aovs else "off")


def main():
    args = checkout_comparison_arguments(__doc__, DEFAULT_SCENES, "another checkout whose colour-only speed to compare", spp=8, resolution=96)
    variants = [("off", ROOT, False), ("on", ROOT, True)]
    if args.baseline:
        variants.append(("baseline", args.baseline.resolve(), False))
    print(f"{args.rounds} interleaved rounds, {args.spp} spp, width {args.resolution}; M samples/s are medians")
    header = f"{'scene':28s} " + " ".join(f"{name:>9s}" for name, _, _ in variants)
    header += f" {'on/off':>7s}" + (f" {'off/base':>9s}" if args.baseline else "")
    print(header)
    for scene in args.scenes:
        rates = interleaved({name: measure(checkout, scene, args.spp, args.resolution, aovs)
                             for name, checkout, aovs in variants}, rounds=args.rounds, warmup=0)
        line = f"{Path(scene).stem:28s} " + " ".join(f"{median(r) / 1e6:9.3f}" for r in rates.values())
        line += f" {median(round_ratios(rates['on'], rates['off'])):7.3f}"
        if args.baseline:
            line += f" {median(round_ratios(rates['off'], rates['baseline'])):9.3f}"
        print(line, flush=True)


if __name__ == "__main__":
    main()
