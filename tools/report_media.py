"""Speed against error for homogeneous media: the smoke Cornell box with a chromatic medium,
rendered for equal time with and without spectral MIS, against a converged reference.

    python tools/report_media.py [--seconds 20] [--reference-spp 4096] [--resolution 128]

The reference (spectral MIS on, which is unbiased for any coefficients) is cached as EXR under
docs/references/; delete it to recompute. Writes docs/media-report.md.
"""
import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
import clrender  # noqa: E402
from clrender.bench import interleaved, timed  # noqa: E402

SCENE = ROOT / "scenes" / "smoke_cornell_box.json"


def load(resolution):
    scene = clrender.load_scene(SCENE)
    scene.camera.resolution = (resolution, resolution)
    return scene


def reference(scene, spp, device):
    path = ROOT / "docs" / "references" / f"smoke_cornell_box_{scene.camera.resolution[0]}px_{spp}spp.exr"
    if not path.exists():
        seconds, result = timed(lambda: clrender.Renderer(scene, device).render(spp=spp, seed=1234))
        clrender.save_image(result.image, path)
        print(f"reference: {spp} spp in {seconds:.0f} s -> {path}")
    return clrender.load_image(path)


def equal_time_render(scene, device, spectral_mis, seconds, seed):
    """A function rendering for `seconds`, its kernel warmed up by a 1-spp render."""
    renderer = clrender.Renderer(scene, device, spectral_mis=spectral_mis)
    renderer.render(spp=1, seed=seed + 99)
    return lambda: renderer.render(seed=seed, time_limit=seconds)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--reference-spp", type=int, default=8192)
    parser.add_argument("--resolution", type=int, default=96)
    parser.add_argument("--device")
    args = parser.parse_args()
    device = clrender.choose_device(args.device)
    scene = load(args.resolution)
    ref = reference(scene, args.reference_spp, device)
    medium = scene.media[0]
    rows = []
    methods = {"spectral MIS (hero channel + balance over RGB)": True, "hero channel only (no spectral MIS)": False}
    results = interleaved({label: equal_time_render(scene, device, mis, args.seconds, seed=7)
                           for label, mis in methods.items()}, rounds=1, warmup=0)
    for label, (result,) in results.items():
        mse = clrender.mse(result.image, ref)
        rows.append((label, result, mse))
        print(f"{label}: {result.samples} spp, {result.seconds:.1f} s, RMSE {mse ** 0.5:.5f}")
    lines = [
        "# Homogeneous media: spectral MIS, speed against error",
        "",
        f"Scene: `scenes/smoke_cornell_box.json` at {args.resolution}x{args.resolution}, smoke sigma_t = "
        f"{(medium.sigma_t).round(3).tolist()}, albedo = {(medium.sigma_s / medium.sigma_t).round(3).tolist()}, "
        f"g = {medium.g}. Reference: {args.reference_spp} spp with spectral MIS. Equal time: about "
        f"{args.seconds:.0f} s of kernel time each, on {device.name.strip()}.",
        "",
        "| method | spp | seconds | M samples/s | RMSE | relative MSE | efficiency 1/(MSE s) |",
        "|---|---|---|---|---|---|---|",
    ]
    for label, result, mse in rows:
        lines.append(f"| {label} | {result.samples} | {result.seconds:.1f} | {result.samples_per_second / 1e6:.3f} | "
                     f"{mse ** 0.5:.5f} | {clrender.relative_mse(result.image, ref):.3g} | "
                     f"{clrender.efficiency(mse, result.seconds):.4g} |")
    lines += ["", "Regenerate: `python tools/report_media.py` (the reference is cached in docs/references/)."]
    out = ROOT / "docs" / "media-report.md"
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
