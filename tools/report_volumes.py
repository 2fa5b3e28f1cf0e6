"""Grid media: the bias of ray marching against its step, and speed against error of both
methods (null scattering, ray marching) on the cloud example scenes. Writes
docs/volume-report.md and docs/volume-report.png.

    python tools/report_volumes.py [--resolution 96] [--reference-spp 8192] [--bias-spp 2048]
        [--steps 4 2 1 0.5] [--spp 4 16 64 256] [--repeats 3] [--scenes NAME ...]

- Reference: null scattering (unbiased) with --reference-spp samples in BATCHES independent
  batches, giving the mean image and its per-pixel variance. Cached under docs/references/ (mean
  and variance EXRs) and reused while both files exist.
- Bias of marching, isolated from its noise: each step is rendered with --bias-spp samples in
  BATCHES batches; per pixel, (m - r)^2 - var(m) - var(r) is an unbiased estimate of the squared
  bias, and its mean over the image the squared RMS bias ("error beyond noise"), given with its
  standard error (every row shares the reference's noise, so their estimates share an offset of
  that size) and a two-standard-error upper bound. The signed bias of the image mean per channel
  is resolved far better (the noise of a mean over all pixels is small).
- Speed against error: both methods at each --spp, interleaved in every repetition (the machine
  is shared, so only ratios measured in the same run mean something); seconds are kernel time
  after a warm-up, the median of --repeats; RMSE against the reference with the reference's own
  variance removed.
- Crossover: with c the seconds per spp (the timed renders at the largest spp) and V the pixel
  variance of one sample (from the batches), null scattering reaches RMSE e in c_n V_n / e^2
  seconds and marching in c_m V_m / (e^2 - b^2), b its RMS bias: marching is faster for every
  RMSE above e* = b / sqrt(1 - c_m V_m / (c_n V_n)), and never if c_m V_m >= c_n V_n. Given for
  b's estimate and (conservatively) for its upper bound.
"""
import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
import clrender  # noqa: E402
from clrender.bench import interleaved, median, timed  # noqa: E402

SCENES = ("cloud_cornell_box", "cloud_low_sun")
BATCHES = 16


def load(name, resolution):
    scene = clrender.load_scene(ROOT / "scenes" / f"{name}.json")
    width, height = scene.camera.resolution
    scene.camera.resolution = (resolution, max(1, round(resolution * height / width)))
    return scene


def batched(renderer, spp, seed):
    """Mean image of `spp` samples in BATCHES independent batches, the per-pixel variance of
    that mean, and the kernel seconds spent."""
    images, seconds = [], 0.0
    for k in range(BATCHES):
        result = renderer.render(spp=max(1, spp // BATCHES), seed=seed + k)
        images.append(result.image.astype(np.float64))
        seconds += result.seconds
    images = np.stack(images)
    return images.mean(axis=0), images.var(axis=0, ddof=1) / BATCHES, seconds


def reference(name, scene, spp, device):
    width, height = scene.camera.resolution
    stem = ROOT / "docs" / "references" / f"{name}_{width}x{height}_{spp}spp_null"
    mean_path, variance_path = stem.with_name(stem.name + ".exr"), stem.with_name(stem.name + "_variance.exr")
    if not (mean_path.exists() and variance_path.exists()):
        seconds, (mean, variance, _) = timed(
            lambda: batched(clrender.Renderer(scene, device, volume_method="null"), spp, seed=100000))
        clrender.save_image(mean.astype(np.float32), mean_path)
        clrender.save_image(variance.astype(np.float32), variance_path)
        print(f"{name}: reference {spp} spp in {seconds:.0f} s -> {mean_path.relative_to(ROOT)}")
    return mean_path, clrender.load_image(mean_path).astype(np.float64), clrender.load_image(variance_path)


def error_beyond_noise(mean, variance, ref, ref_variance):
    """RMS bias of `mean` against the reference, and the standard error of its square."""
    terms = (mean - ref) ** 2 - variance - ref_variance
    squared = terms.mean()
    error = terms.std(ddof=1) / np.sqrt(terms.size)
    return np.sqrt(max(squared, 0.0)), squared, error


def measure_bias(scene, device, ref, ref_variance, steps, spp):
    """Rows for the bias table: marching at each step (multiple scattering), and single scattering
    at the default step."""
    rows = []
    settings = [(step, True) for step in steps] + [(scene.render.step, False)]
    for step, multiple in settings:
        renderer = clrender.Renderer(scene, device, volume_method="raymarch", step=step,
                                     raymarch_multiple_scattering=multiple)
        renderer.render(spp=1, seed=1)   # warm-up: builds the kernel
        mean, variance, seconds = batched(renderer, spp, seed=2000)
        bias, squared, error = error_beyond_noise(mean, variance, ref, ref_variance)
        relative = (mean - ref).sum(axis=(0, 1)) / ref.sum(axis=(0, 1))
        rows.append({"step": step, "multiple": multiple, "bias": bias, "squared": squared, "error": error,
                     "bias_upper": np.sqrt(max(squared + 2 * error, 0.0)),
                     "relative": relative, "pixel_variance": float(variance.mean() * spp),
                     "seconds_per_spp": seconds / spp})
        print(f"  marching step {step:g}{'' if multiple else ' single scattering'}: RMS bias {bias:.5f} "
              f"(b^2 {squared:.3g} +- {error:.2g}), mean bias {np.round(relative * 100, 2)}%", flush=True)
    return rows


def measure_speed(scene, device, ref, ref_variance, spps, repeats, methods):
    """{label: [point per spp]}; all methods of one spp are interleaved in every repetition."""
    renderers = {label: clrender.Renderer(scene, device, **options) for label, options in methods}
    for renderer in renderers.values():
        renderer.render(spp=1, seed=1)
    points = {label: [] for label in renderers}
    for spp in spps:
        runs = interleaved({label: lambda r=renderer, s=spp: r.render(spp=s, seed=7 + s)
                            for label, renderer in renderers.items()}, rounds=repeats, warmup=0)
        for label in renderers:
            mse = np.mean((runs[label][-1].image - ref) ** 2) - ref_variance.mean()
            points[label].append({"spp": spp, "seconds": median([r.seconds for r in runs[label]]),
                                  "rmse": np.sqrt(max(mse, 0.0))})
            print(f"  {label}, {spp} spp: {points[label][-1]['seconds']:.2f} s, RMSE {points[label][-1]['rmse']:.5f}",
                  flush=True)
    return points


def crossover(null_cost, march_cost, bias):
    """The RMSE above which marching is faster (None: never); costs are c V (seconds x variance)."""
    if march_cost >= null_cost:
        return None
    return bias / np.sqrt(1.0 - march_cost / null_cost)


def plot(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(6.2 * len(results), 4.8), squeeze=False)
    for axis, (name, r) in zip(axes[0], results.items()):
        for (label, points), style in zip(r["speed"].items(), ("o-", "s--", "^:", "v-.")):
            axis.loglog([p["seconds"] for p in points], [p["rmse"] for p in points], style, label=label)
            for p in points:
                axis.annotate(f"{p['spp']}", (p["seconds"], p["rmse"]), textcoords="offset points", xytext=(4, 3),
                              fontsize=7)
        model = r["model"]
        longest = max(p["seconds"] for ps in r["speed"].values() for p in ps) * 8
        seconds = np.geomspace(min(p["seconds"] for ps in r["speed"].values() for p in ps) / 2,
                               max(longest, 3 * model.get("crossover_seconds", 0.0)), 100)
        axis.loglog(seconds, np.sqrt(model["null_cost"] / seconds), color="C0", alpha=0.35, lw=4,
                    label="null scattering: model c V / t")
        axis.loglog(seconds, np.sqrt(model["bias"] ** 2 + model["march_cost"] / seconds), color="C1", alpha=0.35,
                    lw=4, label="marching (default step): model b^2 + c V / t")
        axis.axhline(model["bias"], color="C1", ls=":", lw=1, label=f"marching bias b = {model['bias']:.4f}")
        if model["crossover"] is not None:
            axis.axhline(model["crossover"], color="k", ls="--", lw=0.8,
                         label=f"crossover RMSE {model['crossover']:.4f}")
        axis.set_title(f"{name} (labels: spp)")
        axis.set_xlabel("kernel seconds")
        axis.set_ylabel("RMSE against the reference (its noise removed)")
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def scene_section(name, scene, args, ref_path, r):
    width, height = scene.camera.resolution
    medium = next(m for m in scene.media if m.type == "grid")
    nx, ny, nz = medium.grid.resolution
    model = r["model"]
    lines = [
        f"## {name}", "",
        f"`scenes/{name}.json` at {width}x{height}; grid {nx}x{ny}x{nz} ({medium.grid.source}), sigma_t = "
        f"{(medium.sigma_a + medium.sigma_s).round(3).tolist()} per unit density, albedo "
        f"{(medium.sigma_s / (medium.sigma_a + medium.sigma_s)).round(3).tolist()}, g = {medium.g}. "
        f"Reference: `{ref_path.relative_to(ROOT)}` (null scattering, {args.reference_spp} spp, with its "
        "variance image).", "",
        f"### Bias of ray marching ({args.bias_spp} spp per row)", "",
        "| step (voxels) | scattering | mean bias R, G, B (of the image mean) | RMS bias b (error beyond noise) | "
        "b^2 +- standard error | b upper bound | noise: pixel variance x spp | seconds per spp |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in r["bias"]:
        lines.append(f"| {row['step']:g} | {'multiple' if row['multiple'] else 'single'} | "
                     f"{', '.join(f'{100 * v:+.2f}%' for v in row['relative'])} | {row['bias']:.5f} | "
                     f"{row['squared']:.3g} +- {row['error']:.2g} | {row['bias_upper']:.5f} | "
                     f"{row['pixel_variance']:.4g} | {row['seconds_per_spp']:.4f} |")
    lines += ["", "### Speed against error (same run, interleaved)", "",
              "| method | spp | seconds | RMSE |", "|---|---|---|---|"]
    for label, points in r["speed"].items():
        lines += [f"| {label} | {p['spp']} | {p['seconds']:.3f} | {p['rmse']:.5f} |" for p in points]
    ratio = model["march_seconds"] / model["null_seconds"]
    if model["crossover"] is not None:
        verdict = (f"marching at its default step reaches a given RMSE faster than null scattering down to an RMSE "
                   f"of **{model['crossover']:.4f}** (with b's upper bound: {model['crossover_upper']:.4f}), where its "
                   f"bias takes over; null scattering needs {model['crossover_seconds']:.3g} s "
                   f"({model['crossover_spp']:.0f} spp) to get there at this resolution")
    else:
        verdict = "marching at its default step is not faster than null scattering at any RMSE here"
    lines += ["", f"Model (seconds per spp c from the timed renders at {args.spp[-1]} spp, pixel variance per spp V "
              f"from the batches): null c V = {model['null_cost']:.4g}, marching c V = {model['march_cost']:.4g} "
              f"(seconds per spp x{ratio:.2f} of null's, variance x{model['march_variance'] / model['null_variance']:.2f}"
              f"), marching's RMS bias b = {model['bias']:.5f} (upper bound {model['bias_upper']:.5f}): {verdict}.", ""]
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--resolution", type=int, default=96, help="image width (height keeps the aspect)")
    parser.add_argument("--reference-spp", type=int, default=8192)
    parser.add_argument("--bias-spp", type=int, default=2048)
    parser.add_argument("--steps", type=float, nargs="*", default=[4.0, 2.0, 1.0, 0.5])
    parser.add_argument("--spp", type=int, nargs="*", default=[4, 16, 64, 256])
    parser.add_argument("--scenes", nargs="*", default=list(SCENES))
    parser.add_argument("--repeats", type=int, default=3, help="timed renders per setting (median)")
    parser.add_argument("--device")
    args = parser.parse_args()
    device = clrender.choose_device(args.device)
    results, lines = {}, []
    for name in args.scenes:
        print(f"{name}:", flush=True)
        scene = load(name, args.resolution)
        ref_path, ref, ref_variance = reference(name, scene, args.reference_spp, device)
        bias = measure_bias(scene, device, ref, ref_variance, args.steps, args.bias_spp)
        default = scene.render.step
        methods = [("null scattering", {"volume_method": "null"}),
                   (f"ray marching, step {default:g} (default)", {"volume_method": "raymarch"}),
                   (f"ray marching, step {2 * default:g}", {"volume_method": "raymarch", "step": 2 * default})]
        speed = measure_speed(scene, device, ref, ref_variance, args.spp, args.repeats, methods)
        march = next(row for row in bias if row["step"] == default and row["multiple"])
        null_variance = float(ref_variance.mean() * args.reference_spp)
        null_seconds = speed[methods[0][0]][-1]["seconds"] / args.spp[-1]
        march_seconds = speed[methods[1][0]][-1]["seconds"] / args.spp[-1]
        model = {"null_variance": null_variance, "march_variance": march["pixel_variance"],
                 "null_seconds": null_seconds, "march_seconds": march_seconds,
                 "null_cost": null_seconds * null_variance, "march_cost": march_seconds * march["pixel_variance"],
                 "bias": march["bias"], "bias_upper": march["bias_upper"]}
        model["crossover"] = crossover(model["null_cost"], model["march_cost"], model["bias"])
        if model["crossover"] is not None:
            model["crossover_upper"] = crossover(model["null_cost"], model["march_cost"], model["bias_upper"])
            model["crossover_seconds"] = model["null_cost"] / model["crossover"] ** 2
            model["crossover_spp"] = model["crossover_seconds"] / null_seconds
        results[name] = {"bias": bias, "speed": speed, "model": model}
        lines += scene_section(name, scene, args, ref_path, results[name])
    plot(results, ROOT / "docs" / "volume-report.png")
    header = [
        "# Grid media: the bias of ray marching, and speed against error", "",
        f"Generated by `python tools/report_volumes.py --resolution {args.resolution} --reference-spp "
        f"{args.reference_spp} --bias-spp {args.bias_spp} --steps {' '.join(f'{s:g}' for s in args.steps)} "
        f"--spp {' '.join(map(str, args.spp))} --repeats {args.repeats}` on {device.name.strip()} (2 cores shared "
        "with other work: seconds are only comparable within one scene's table, where the methods were timed "
        "interleaved). How each number is obtained: the docstring of `tools/report_volumes.py`. "
        "Plot: `docs/volume-report.png`.", "",
    ]
    out = ROOT / "docs" / "volume-report.md"
    out.write_text("\n".join(header + lines))
    print(f"wrote {out.relative_to(ROOT)} and docs/volume-report.png")


if __name__ == "__main__":
    main()
