"""Cost of the camera's options in both kernels (the megakernel and the packets): a scene
rendered with the box filter and a pinhole (the defaults) against the gaussian and the tent
filters (kernels/filter.h), a thin lens (kernels/camera.h) and, with --baseline, another
checkout's defaults (the code before them).

    python tools/bench_camera.py [scenes...] [--baseline /path/to/other/checkout] [--rounds 5]
        [--spp 256] [--resolution 128]

Rates are samples per CPU second of the worker process (PoCL's threads included), steadier than
wall time on a shared machine. Every variant runs in a fresh process per round (clrender.bench's
checkout_worker: warm-up render, median of three), the variants interleaved round by round;
ratios are the medians of the per-round ratios to the box.
"""
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from clrender.bench import checkout_comparison_arguments, checkout_worker, interleaved, median, round_ratios  # noqa: E402

DEFAULT_SCENES = ["scenes/cornell_box.json"]
# name -> the camera's settings (JSON fields), applied after loading the scene
CAMERAS = {"box": {}, "gaussian": {"filter": {"type": "gaussian"}}, "tent": {"filter": {"type": "tent"}},
           "thinlens": {"aperture_radius": 0.05}}

WORKER = """
import importlib.util, json, os, sys
from pathlib import Path
import clrender
bench_path, scene_path, spp, resolution, packets, camera = sys.argv[1:7]
spec = importlib.util.spec_from_file_location("bench", bench_path)
bench = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench)
data = clrender.scene.read_json(Path(scene_path))
data["camera"].update(json.loads(camera))
scene = clrender.load_scene_dict(data, base_dir=Path(scene_path).parent)
width, height = scene.camera.resolution
resolution, spp = int(resolution), int(spp)
scene.camera.resolution = (resolution, max(1, round(resolution * height / width)))
renderer = clrender.Renderer(scene, packets=packets == "packets")
def cpu_seconds():
    times = os.times()
    return times.user + times.system
def rate():   # renders until 0.5 CPU s have passed: the clock ticks in hundredths
    start, samples = cpu_seconds(), 0
    while cpu_seconds() - start < 0.5:
        samples += renderer.render(spp=spp, samples_per_pass=spp).samples * resolution * scene.camera.resolution[1]
    return samples / (cpu_seconds() - start)
runs = bench.interleaved({"rate": rate}, rounds=3)
print(json.dumps(bench.median(runs["rate"])))
"""


def measure(checkout, scene, spp, resolution, packets, camera):
    """A function running one worker process in `checkout`, returning its samples per CPU second."""
    return checkout_worker(checkout, WORKER, ROOT / "clrender" / "bench.py", ROOT / scene, spp, resolution,
                           "packets" if packets else "megakernel", json.dumps(camera))


def main():
    args = checkout_comparison_arguments(__doc__, DEFAULT_SCENES, "another checkout, rendering with its box filter", spp=256, resolution=128)
    variants = {name: (ROOT, camera) for name, camera in CAMERAS.items()}
    if args.baseline:
        variants["baseline"] = (args.baseline.resolve(), {})
    print(f"{args.rounds} interleaved rounds, {args.spp} spp, width {args.resolution}; M samples per CPU second, medians; "
          "x: median per-round ratio to the box")
    print(f"{'scene':28s} {'kernel':10s} " + " ".join(f"{name:>17s}" for name in variants))
    for scene in args.scenes:
        for packets in (False, True):
            rates = interleaved({name: measure(checkout, scene, args.spp, args.resolution, packets, camera)
                                 for name, (checkout, camera) in variants.items()}, rounds=args.rounds, warmup=0)
            cells = [f"{median(r) / 1e6:7.3f} x{median(round_ratios(r, rates['box'])):.3f}" for r in rates.values()]
            print(f"{Path(scene).stem:28s} {'packets' if packets else 'megakernel':10s} " + " ".join(
                f"{cell:>17s}" for cell in cells), flush=True)


if __name__ == "__main__":
    main()
