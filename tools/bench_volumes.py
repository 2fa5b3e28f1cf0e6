"""Null scattering against ray marching (default settings) on the configuration of issue 11:
a 64^3 noise cloud (sigma_t 20 per unit density, albedo 0.9) in the Cornell box, 256 x 256,
64 spp. Prints the kernel seconds of both (the median of --repeats, the methods interleaved in
every repetition, so their ratio holds on a shared machine) and the ratio of the image means.

    python tools/bench_volumes.py [--resolution 256] [--spp 64] [--repeats 3]
"""
import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
import clrender  # noqa: E402
from clrender.bench import interleaved, median  # noqa: E402


def scene(resolution):
    data = json.loads((ROOT / "scenes" / "cloud_cornell_box.json").read_text())
    data["camera"]["resolution"] = [resolution, resolution]
    cloud = data["media"][0]
    cloud["density"] = {"procedural": "noise_cloud", "resolution": [64, 64, 64], "seed": 7}
    cloud["sigma_t"], cloud["albedo"] = 20.0, 0.9
    return clrender.load_scene_dict(data)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--device")
    args = parser.parse_args()
    device = clrender.choose_device(args.device)
    s = scene(args.resolution)
    renderers = {method: clrender.Renderer(s, device, volume_method=method) for method in ("null", "raymarch")}
    for renderer in renderers.values():
        renderer.render(spp=1, seed=99)   # warm-up: builds the kernel
    runs = interleaved({method: lambda r=renderer: r.render(spp=args.spp, seed=1)
                        for method, renderer in renderers.items()}, rounds=args.repeats, warmup=0)
    null, march = (median([result.seconds for result in runs[m]]) for m in ("null", "raymarch"))
    means = {method: results[-1].image.mean(axis=(0, 1)) for method, results in runs.items()}
    print(f"{args.resolution}x{args.resolution}, {args.spp} spp on {device.name.strip()}")
    print(f"null scattering: {null:.2f} s; ray marching (step {s.render.step:g} voxels, multiple scattering): "
          f"{march:.2f} s = {march / null:.2f}x; image mean marching / null: "
          f"{', '.join(f'{v:.4f}' for v in means['raymarch'] / means['null'])}")


if __name__ == "__main__":
    main()
