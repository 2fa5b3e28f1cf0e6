"""Speed against error for grid media: the null-scattering path integral and ray marching.

For each cloud scene: a converged reference (null scattering, many spp; cached as EXR under
docs/references/, reused while its file exists), then each method at several settings (spp;
step sizes and single/multiple scattering for marching), each with its kernel seconds, RMSE,
relative MSE and efficiency 1 / (MSE x seconds). Writes docs/volume-report.md (tables) and
docs/volume-report.png (error against time, log-log).

    python tools/report_volumes.py [--resolution 96] [--reference-spp 2048] [--scenes NAME ...]

Timings are kernel time on the chosen device after a warm-up launch, the median of --repeats
renders; on a shared machine they vary by some 10%, so compare ratios rather than absolute figures.
"""
import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
import clrender  # noqa: E402
from clrender.bench import interleaved, median  # noqa: E402

SCENES = ("cloud_cornell_box", "cloud_low_sun")
NULL_SPP = (4, 16, 64)
MARCH_SPP = (4, 16)
STEP_FACTORS = (4, 2, 1)       # multiples of the scene's step


def load(name, resolution):
    scene = clrender.load_scene(ROOT / "scenes" / f"{name}.json")
    width, height = scene.camera.resolution
    scene.camera.resolution = (resolution, max(1, round(resolution * height / width)))
    return scene


def reference(name, scene, spp, device):
    width, height = scene.camera.resolution
    path = ROOT / "docs" / "references" / f"{name}_{width}x{height}_{spp}spp_null.exr"
    if not path.exists():
        start = time.perf_counter()
        result = clrender.Renderer(scene, device, volume_method="null").render(spp=spp, seed=1234)
        clrender.save_image(result.image, path)
        print(f"{name}: reference {spp} spp in {time.perf_counter() - start:.0f} s -> {path.relative_to(ROOT)}")
    return path, clrender.load_image(path)


def measure(scene, device, ref, spp, seed, repeats, **options):
    """Error of one render; its time the median of `repeats` identical renders (same seed)."""
    renderer = clrender.Renderer(scene, device, **options)
    # The warm-up's first launch compiles the kernel.
    results = interleaved({"render": lambda: renderer.render(spp=spp, seed=seed)}, rounds=repeats)["render"]
    result = results[0]
    seconds = median([r.seconds for r in results])
    mse = clrender.mse(result.image, ref)
    return {"spp": spp, "seconds": seconds, "rmse": mse ** 0.5, "mse": mse,
            "relmse": clrender.relative_mse(result.image, ref),
            "efficiency": clrender.efficiency(mse, seconds),
            "discarded": result.discarded_samples, "image": result.image}


def runs_for(scene):
    """(label, options, spp list) for every setting compared."""
    step = scene.render.step
    runs = [("null scattering", {"volume_method": "null"}, NULL_SPP)]
    for factor in STEP_FACTORS:
        runs.append((f"ray marching, multiple scattering, step {step * factor:g}",
                     {"volume_method": "raymarch", "step": step * factor, "raymarch_multiple_scattering": True},
                     MARCH_SPP))
    runs.append((f"ray marching, single scattering, step {step:g}",
                 {"volume_method": "raymarch", "step": step, "raymarch_multiple_scattering": False}, MARCH_SPP[-1:]))
    return runs


def plot(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(6 * len(results), 4.6), squeeze=False)
    for axis, (name, rows) in zip(axes[0], results.items()):
        for label, points in rows:
            seconds = [p["seconds"] for p in points]
            rmse = [p["rmse"] for p in points]
            style = "o-" if label.startswith("null") else ("s--" if "multiple" in label else "^:")
            axis.loglog(seconds, rmse, style, label=label)
            for p in points:
                axis.annotate(f"{p['spp']}", (p["seconds"], p["rmse"]), textcoords="offset points",
                              xytext=(4, 3), fontsize=7)
        axis.set_title(f"{name} (labels: spp)")
        axis.set_xlabel("kernel seconds")
        axis.set_ylabel("RMSE against the reference")
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--resolution", type=int, default=96, help="image width (height keeps the aspect)")
    parser.add_argument("--reference-spp", type=int, default=2048)
    parser.add_argument("--scenes", nargs="*", default=list(SCENES))
    parser.add_argument("--repeats", type=int, default=3, help="timed renders per setting (median)")
    parser.add_argument("--device")
    args = parser.parse_args()
    device = clrender.choose_device(args.device)
    results, lines = {}, []
    for name in args.scenes:
        scene = load(name, args.resolution)
        ref_path, ref = reference(name, scene, args.reference_spp, device)
        rows = []
        for label, options, spps in runs_for(scene):
            points = [measure(scene, device, ref, spp, 7 + spp, args.repeats, **options) for spp in spps]
            rows.append((label, points))
            for p in points:
                print(f"{name}: {label}, {p['spp']} spp: {p['seconds']:.2f} s, RMSE {p['rmse']:.5f}")
        results[name] = rows
        width, height = scene.camera.resolution
        medium = next(m for m in scene.media if m.type == "grid")
        nx, ny, nz = medium.grid.resolution
        lines += [
            f"## {name}", "",
            f"`scenes/{name}.json` at {width}x{height}; grid {nx}x{ny}x{nz} ({medium.grid.source}), sigma_t = "
            f"{(medium.sigma_a + medium.sigma_s).round(3).tolist()} per unit density, albedo "
            f"{(medium.sigma_s / (medium.sigma_a + medium.sigma_s)).round(3).tolist()}, g = {medium.g}. "
            f"Reference: `{ref_path.relative_to(ROOT)}` (null scattering, {args.reference_spp} spp).", "",
            "| method | spp | seconds | RMSE | relative MSE | efficiency 1/(MSE s) |",
            "|---|---|---|---|---|---|",
        ]
        for label, points in rows:
            for p in points:
                note = f" ({p['discarded']} non-finite samples)" if p["discarded"] else ""
                lines.append(f"| {label}{note} | {p['spp']} | {p['seconds']:.2f} | {p['rmse']:.5f} | "
                             f"{p['relmse']:.4g} | {p['efficiency']:.4g} |")
        best = {}
        for label, points in rows:
            kind = "null" if label.startswith("null") else ("marching" if "multiple" in label else "single")
            for p in points:
                if kind not in best or p["efficiency"] > best[kind]["efficiency"]:
                    best[kind] = dict(p, label=label)
        null, march = best["null"], best["marching"]
        lines += ["", f"Most efficient: {null['label']} at {null['spp']} spp ({null['efficiency']:.4g}) against "
                  f"{march['label']} at {march['spp']} spp ({march['efficiency']:.4g}): "
                  f"{null['efficiency'] / march['efficiency']:.1f}x in favour of "
                  f"{'null scattering' if null['efficiency'] > march['efficiency'] else 'ray marching'}.", ""]
    plot(results, ROOT / "docs" / "volume-report.png")
    header = [
        "# Grid media: speed against error", "",
        f"Generated by `python tools/report_volumes.py --resolution {args.resolution} --reference-spp "
        f"{args.reference_spp}` on {device.name.strip()}. Seconds are kernel time after a warm-up launch, "
        f"the median of {args.repeats} renders (the machine is shared: expect some 10% jitter). RMSE and relative MSE are against the "
        "cached reference, whose own noise is included (small next to every row here: it has 32x or "
        "more the spp of any row). Efficiency 1/(MSE x seconds) is independent of spp only for the "
        "unbiased method; for marching, the error stops falling with spp once the bias dominates, "
        "and a smaller step lowers the bias at a higher cost per sample. Plot: `docs/volume-report.png`.",
        "",
    ]
    out = ROOT / "docs" / "volume-report.md"
    out.write_text("\n".join(header + lines))
    print(f"wrote {out.relative_to(ROOT)} and docs/volume-report.png")


if __name__ == "__main__":
    main()
