"""How closely clrender's images agree with Mitsuba 3's on the parity scenes (the XML files of
tests/mitsuba_scenes.py and scenes/cornell_box.xml): per scene, the relative difference of the
image means with its z-score, and the largest |z| over 4 x 4 pixel blocks, from RENDERS
renders per renderer (Mitsuba: scalar_rgb).

    python3 tools/mitsuba_parity.py --spp 1024 --renders 8 > table.md
"""
import argparse
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

import clrender  # noqa: E402
import mitsuba_scenes  # noqa: E402
from clrender.bench import timed  # noqa: E402


def render(path, spp, renders, device, **parameters):
    import mitsuba as mi

    parameters = {"spp": str(spp), **{k: str(v) for k, v in parameters.items()}}
    def render_mitsuba():
        theirs = mi.load_file(str(path), **parameters)
        return np.array([np.array(mi.render(theirs, spp=spp, seed=seed)) for seed in range(renders)])

    mitsuba_seconds, mitsuba = timed(render_mitsuba)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = clrender.load_scene(path, parameters=parameters)
    renderer = clrender.Renderer(scene, device)
    ours = np.array([renderer.render(spp=spp, seed=1000 + seed).image for seed in range(renders)])
    return ours, mitsuba, mitsuba_seconds


def statistics(ours, mitsuba, block=4):
    count = len(ours)
    difference = ours.mean(0) - mitsuba.mean(0)
    variance = (ours.var(0, ddof=1) + mitsuba.var(0, ddof=1)) / count
    h, w, _ = difference.shape
    d = difference.reshape(h // block, block, w // block, block, 3).mean(axis=(1, 3))
    v = variance.reshape(h // block, block, w // block, block, 3).sum(axis=(1, 3)) / block ** 4
    block_z = np.where(v > 0, d / np.sqrt(np.where(v > 0, v, 1)), 0)
    image_d = difference.mean(axis=(0, 1))
    image_z = image_d / np.sqrt(variance.sum(axis=(0, 1)) / (h * w) ** 2)
    return image_d / mitsuba.mean(axis=(0, 1, 2)), image_z, np.abs(block_z).max()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spp", type=int, default=1024)
    parser.add_argument("--renders", type=int, default=8)
    parser.add_argument("--res", type=int, default=16)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--scenes", nargs="*", help="only these (names of tests/mitsuba_scenes.py, or cornell_box)")
    args = parser.parse_args()
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    device = clrender.choose_device(args.device)
    print(f"{args.res} x {args.res} pixels, {args.spp} spp x {args.renders} renders per renderer "
          f"(Mitsuba {mi.__version__} scalar_rgb)\n")
    print("| scene | mean rel. difference (R, G, B) | image z (R, G, B) | max block abs z | Mitsuba s |")
    print("|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        wanted = set(args.scenes or [*mitsuba_scenes.SCENES, "cornell_box"])
        cases = [(name, mitsuba_scenes.write(Path(folder), name), {"res": args.res})
                 for name in sorted(mitsuba_scenes.SCENES) if name in wanted]
        if "cornell_box" in wanted:
            cases += [(f"cornell_box max_depth {depth}", ROOT / "scenes" / "cornell_box.xml",
                       {"resolution": args.res, "max_depth": depth}) for depth in (2, 8)]
        for name, path, parameters in cases:
            ours, mitsuba, seconds = render(path, args.spp, args.renders, device, **parameters)
            relative, image_z, block_z = statistics(ours, mitsuba)
            print(f"| {name} | {', '.join(f'{r:+.2%}' for r in relative)} | "
                  f"{', '.join(f'{z:+.1f}' for z in image_z)} | {block_z:.1f} | {seconds:.1f} |", flush=True)


if __name__ == "__main__":
    main()
