"""Denoising (Intel Open Image Denoise): speed against error, raw and denoised.

For each scene, at each sample count: the raw render (colour only) and the denoised one (the
render with the albedo and normal AOVs, then OIDN, hdr, high quality; and with the guides
prefiltered), their RMSE and relative MSE against a converged reference, and their times
(kernel seconds; denoised: the AOV render plus the denoiser's wall time). Then the equal-time
comparison: a raw render given the time the denoised one took. In media scenes the errors are
also taken over the pixels whose centre ray crosses the medium (where thin volumes lose detail).

    python tools/report_denoising.py [--resolution 128] [--spps 1 4 16 64 256] [--scenes ...]

    python tools/report_denoising.py --test-reference   # only (re)write the reference of the tests

Writes docs/denoising-report.md, docs/denoising-plot.png (error against time) and
docs/denoising-images.png (crops). References are rendered once and cached outside git in
$CLRENDER_REFERENCE_DIR (default ~/.cache/clrender/references); a reference of the same scene,
size and spp already committed under docs/references/ is used instead.
"""
import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
import clrender  # noqa: E402
from clrender.image import tonemap  # noqa: E402

# name -> reference spp; scenes/NAME.json
SCENES = {"cornell_box": 8192, "cornell_glass": 8192, "smoke_cornell_box": 4096, "cloud_low_sun": 8192}
REFERENCE_SEED = 1234
# tests/test_denoise.py's reference: the Cornell box at its own 256 x 256, 4096 spp, seed 1000,
# stored as half floats (220 kB; relative MSE 1e-8 from the float image, its noise 4e-5).
TEST_REFERENCE = ROOT / "docs" / "references" / "cornell_box_256px_4096spp.exr"
SEED = 7
EPSILON = 1e-2   # of clrender.relative_mse


def load(name, width):
    scene = clrender.load_scene(ROOT / "scenes" / f"{name}.json")
    w, h = scene.camera.resolution
    scene.camera.resolution = (width, max(1, round(width * h / w)))
    return scene


def reference(name, scene, spp, device):
    """(path, image): committed under docs/references/ or cached, else rendered now."""
    w, h = scene.camera.resolution
    committed = [ROOT / "docs" / "references" / f"{name}_{w}x{h}_{spp}spp.exr"]
    if w == h:
        committed.append(ROOT / "docs" / "references" / f"{name}_{w}px_{spp}spp.exr")
    cache = Path(os.environ.get("CLRENDER_REFERENCE_DIR") or Path.home() / ".cache" / "clrender" / "references")
    for path in committed + [cache / f"{name}_{w}x{h}_{spp}spp.exr"]:
        if path.exists():
            return path, clrender.load_image(path)
    start = time.perf_counter()
    image = clrender.Renderer(scene, device).render(spp=spp, seed=REFERENCE_SEED).image
    clrender.save_image(image, path)
    print(f"{name}: reference {spp} spp in {time.perf_counter() - start:.0f} s -> {path}", flush=True)
    return path, image


def write_test_reference(device):
    import OpenEXR

    scene = clrender.load_scene(ROOT / "scenes" / "cornell_box.json")
    image = clrender.Renderer(scene, device).render(spp=4096, seed=1000).image
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": image.astype(np.float16)}) as exr:
        exr.write(str(TEST_REFERENCE))
    print(f"wrote {TEST_REFERENCE.relative_to(ROOT)}")


def medium_region(scene, aux):
    """Pixels whose centre ray crosses a medium: the interior of a shape with an `interface`
    material (its object id), or the box of a grid medium filling the scene; None without media."""
    ids = [i for i, s in enumerate(scene.shapes) if s.interior >= 0]
    if ids:
        return np.isin(aux["object_id"], ids)
    grids = [m for m in scene.media if m.type == "grid"]
    if not grids:
        return None
    lo, hi = grids[0].grid.world_bounds()
    width, height = scene.camera.resolution
    px, py = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    d = scene.camera.pixel_directions(px, py)
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - scene.camera.position) / d, (hi - scene.camera.position) / d
    near = np.max(np.minimum(t0, t1), axis=-1)
    far = np.min(np.maximum(t0, t1), axis=-1)
    region = far > np.maximum(near, 0.0)
    depth = np.where(aux["object_id"] >= 0, aux["depth"], np.inf)   # stop at the first surface
    forward = scene.camera.basis()[0]
    return region & (np.maximum(near, 0.0) * (d @ forward) < depth)


def errors(image, ref, region):
    out = {"rmse": clrender.rmse(image, ref), "relmse": clrender.relative_mse(image, ref)}
    if region is not None and region.any():
        out["region_relmse"] = clrender.relative_mse(image[region], ref[region])
    return out


def measure(scene, device, ref, spps, region):
    """Rows of raw / denoised / prefiltered errors and times per spp, plus equal-time raw renders."""
    plain = clrender.Renderer(scene, device, pass_seconds=0.1)
    with_aovs = clrender.Renderer(scene, device, pass_seconds=0.1)
    plain.render(spp=1, seed=SEED + 1)                                     # warm-up: build, JIT
    with_aovs.render(spp=1, seed=SEED + 1, aovs=("albedo", "normal"))
    clrender.denoise(ref, np.zeros_like(ref), np.zeros_like(ref))        # load OIDN's weights
    rows = []
    for spp in spps:
        raw = plain.render(spp=spp, seed=SEED)
        aov = with_aovs.render(spp=spp, seed=SEED, aovs=("albedo", "normal", "variance"))
        assert np.array_equal(raw.image, aov.image)   # the AOVs never change the colour
        start = time.perf_counter()
        denoised = clrender.denoise(aov.image, aov.aovs["albedo"], aov.aovs["normal"])
        denoise_seconds = time.perf_counter() - start
        start = time.perf_counter()
        prefiltered = clrender.denoise(aov.image, aov.aovs["albedo"], aov.aovs["normal"], prefilter=True)
        prefilter_seconds = time.perf_counter() - start
        rows.append({
            "spp": spp, "raw_seconds": raw.seconds, "aov_seconds": aov.seconds,
            "denoise_seconds": denoise_seconds, "prefilter_seconds": prefilter_seconds,
            "raw": errors(raw.image, ref, region), "denoised": errors(denoised, ref, region),
            "prefiltered": errors(prefiltered, ref, region),
            # The raw image's expected relative MSE from its variance AOV: sum over pixels of
            # var / (ref^2 + eps), checked against the measured one.
            "predicted_raw_relmse": float(np.mean(aov.aovs["variance"] / (ref ** 2 + EPSILON))),
            "sample_variance": aov.aovs["variance"] * spp,
            "images": {"raw": raw.image, "denoised": denoised},
        })
    # Equal time: the spp a raw render affords in the denoised time, at the raw rate of the
    # longest render (the most precise timing).
    seconds_per_spp = rows[-1]["raw_seconds"] / rows[-1]["spp"]
    for r in rows:
        equal = plain.render(spp=max(1, round((r["aov_seconds"] + r["denoise_seconds"]) / seconds_per_spp)),
                             seed=SEED)
        r.update(equal_spp=equal.samples, equal_seconds=equal.seconds, equal=errors(equal.image, ref, region))
        print(f"  {r['spp']:4d} spp: raw {r['raw']['relmse']:.4g} ({r['raw_seconds']:.2f} s), denoised "
              f"{r['denoised']['relmse']:.4g} ({r['aov_seconds'] + r['denoise_seconds']:.2f} s), prefiltered "
              f"{r['prefiltered']['relmse']:.4g}; equal time: raw {equal.samples} spp ({equal.seconds:.2f} s) "
              f"{r['equal']['relmse']:.4g}", flush=True)
    return rows


def reference_floor(rows, ref, ref_spp):
    """The reference's own contribution to every relative MSE: its variance (estimated from the
    highest-spp render's variance AOV, per sample) / its spp, over ref^2 + eps."""
    top = rows[-1]["sample_variance"]
    return float(np.mean(np.where(np.isfinite(top), top, 0.0) / ref_spp / (ref ** 2 + EPSILON)))


def table(name, scene, ref_path, ref_spp, rows, floor):
    width, height = scene.camera.resolution
    region = "region_relmse" in rows[0]["raw"]
    lines = [f"## {name}", "",
             f"`scenes/{name}.json` at {width}x{height}. Reference: `{display_path(ref_path)}` ({ref_spp} spp); "
             f"its own noise adds about {floor:.2g} to every relative MSE below.", "",
             "| spp | raw s | raw RMSE | raw relMSE | denoised s | denoised RMSE | denoised relMSE "
             "| prefiltered s | prefiltered relMSE | equal-time raw spp (s) | its relMSE |"
             + (" raw relMSE in medium | denoised relMSE in medium |" if region else ""),
             "|---|---|---|---|---|---|---|---|---|---|---|" + ("---|---|" if region else "")]
    for r in rows:
        den_s = r["aov_seconds"] + r["denoise_seconds"]
        pre_s = r["aov_seconds"] + r["prefilter_seconds"]
        line = (f"| {r['spp']} | {r['raw_seconds']:.2f} | {r['raw']['rmse']:.4f} | {r['raw']['relmse']:.4g} | "
                f"{den_s:.2f} | {r['denoised']['rmse']:.4f} | {r['denoised']['relmse']:.4g} | {pre_s:.2f} | "
                f"{r['prefiltered']['relmse']:.4g} | {r['equal_spp']} ({r['equal_seconds']:.2f}) | "
                f"{r['equal']['relmse']:.4g} |")
        if region:
            line += f" {r['raw']['region_relmse']:.4g} | {r['denoised']['region_relmse']:.4g} |"
        lines.append(line)
    lines.append("")
    worse = [r["spp"] for r in rows if r["denoised"]["relmse"] > r["raw"]["relmse"]]
    lines.append("Denoising raises the relative MSE at " + (", ".join(f"{s} spp" for s in worse) if worse
                                                            else "no sample count measured") + ".")
    if region:
        worse = [r["spp"] for r in rows if r["denoised"]["region_relmse"] > r["raw"]["region_relmse"]]
        lines.append("In the medium it does so at " + (", ".join(f"{s} spp" for s in worse) if worse
                                                        else "no sample count measured") + ".")
    best_raw = min(rows, key=lambda r: r["raw"]["relmse"])
    matched = [r for r in rows if r["denoised"]["relmse"] <= best_raw["raw"]["relmse"]]
    if matched:
        r = matched[0]
        lines.append(f"Denoised {r['spp']} spp ({r['aov_seconds'] + r['denoise_seconds']:.2f} s) is as good as "
                     f"raw {best_raw['spp']} spp ({best_raw['raw_seconds']:.2f} s).")
    lines += ["", "Raw relative MSE predicted from the variance AOV (sum of var / (ref^2 + eps)) against "
              "measured: " + ", ".join(f"{r['spp']} spp {r['predicted_raw_relmse'] + floor:.3g} / "
                                       f"{r['raw']['relmse']:.3g}" for r in rows if r["spp"] > 1) + ".", ""]
    return lines


def display_path(path):
    try:
        return str(Path(path).relative_to(ROOT))
    except ValueError:
        return str(path).replace(str(Path.home()), "~")


def plot(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(4.6 * len(results), 4.2), squeeze=False)
    for axis, (name, (rows, floor)) in zip(axes[0], results.items()):
        raw_t = [r["raw_seconds"] for r in rows]
        den_t = [r["aov_seconds"] + r["denoise_seconds"] for r in rows]
        pre_t = [r["aov_seconds"] + r["prefilter_seconds"] for r in rows]
        axis.loglog(raw_t, [r["raw"]["relmse"] for r in rows], "o-", label="raw")
        axis.loglog(den_t, [r["denoised"]["relmse"] for r in rows], "s-", label="denoised")
        axis.loglog(pre_t, [r["prefiltered"]["relmse"] for r in rows], "^:", label="denoised, prefiltered guides")
        for r, t in zip(rows, den_t):
            axis.annotate(str(r["spp"]), (t, r["denoised"]["relmse"]), textcoords="offset points",
                          xytext=(4, 3), fontsize=7)
        for r in rows:
            axis.annotate(str(r["spp"]), (r["raw_seconds"], r["raw"]["relmse"]), textcoords="offset points",
                          xytext=(4, 3), fontsize=7)
        axis.axhline(floor, color="grey", lw=0.8, ls="--", label="reference noise")
        axis.set_title(f"{name} (labels: spp)")
        axis.set_xlabel("seconds (denoised: render + denoise)")
        axis.set_ylabel("relative MSE")
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def contact_sheet(results, refs, spps, path):
    """Per scene one row: raw and denoised at each of `spps`, then the reference."""
    import imageio.v3 as iio

    rows = []
    for name, (rows_, _) in results.items():
        by_spp = {r["spp"]: r for r in rows_}
        tiles = []
        for spp in spps:
            tiles += [by_spp[spp]["images"]["raw"], by_spp[spp]["images"]["denoised"]]
        tiles.append(refs[name])
        height = max(t.shape[0] for t in tiles)
        padded = [np.pad(tonemap(t), ((0, height - t.shape[0]), (0, 2), (0, 0)), constant_values=255) for t in tiles]
        rows.append(np.concatenate(padded, axis=1))
    width = max(r.shape[1] for r in rows)
    sheet = np.concatenate([np.pad(r, ((0, 2), (0, width - r.shape[1]), (0, 0)), constant_values=255) for r in rows])
    iio.imwrite(path, sheet)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--resolution", type=int, default=128, help="image width (height keeps the aspect)")
    parser.add_argument("--spps", type=int, nargs="*", default=[1, 4, 16, 64, 256])
    parser.add_argument("--scenes", nargs="*", default=list(SCENES))
    parser.add_argument("--reference-spp", type=int, help="for every scene (default: per scene, SCENES)")
    parser.add_argument("--device")
    parser.add_argument("--test-reference", action="store_true", help="only write the tests' reference")
    args = parser.parse_args()
    device = clrender.choose_device(args.device)
    if args.test_reference:
        return write_test_reference(device)
    results, refs, lines = {}, {}, []
    started = time.strftime("%Y-%m-%d %H:%M")
    load_before = os.getloadavg()[0]
    for name in args.scenes:
        scene = load(name, args.resolution)
        ref_spp = args.reference_spp or SCENES[name]
        ref_path, ref = reference(name, scene, ref_spp, device)
        centre = clrender.Renderer(scene, device).render(spp=1, seed=SEED)
        region = medium_region(scene, centre.aux)
        print(f"{name}:", flush=True)
        rows = measure(scene, device, ref, args.spps, region)
        floor = reference_floor(rows, ref, ref_spp)
        results[name], refs[name] = (rows, floor), ref
        lines += table(name, scene, ref_path, ref_spp, rows, floor)
    plot(results, ROOT / "docs" / "denoising-plot.png")
    contact_sheet(results, refs, [s for s in (4, 16, 256) if s in args.spps], ROOT / "docs" / "denoising-images.png")
    header = [
        "# Denoising: speed against error (generated)", "",
        f"Generated by `python tools/report_denoising.py --resolution {args.resolution} --spps "
        f"{' '.join(map(str, args.spps))}` on {device.name.strip()}, {started}; load average "
        f"{load_before:.1f} at the start on 2 shared cores, so times carry some 10-20% jitter (one render each). "
        "Times: raw = kernel seconds of the colour-only render; denoised = kernel seconds of the render with "
        "the albedo and normal AOVs plus the wall time of Open Image Denoise (CPU, hdr, high quality); "
        "prefiltered = the same with the guides denoised first (cleanAux). Equal-time raw: a colour-only "
        f"render given the denoised time. Relative MSE: mean of (x - ref)^2 / (ref^2 + {EPSILON:g}). "
        "Discussion: `docs/denoising.md`. Plot: `docs/denoising-plot.png`; images (per scene raw and "
        f"denoised at {', '.join(str(s) for s in (4, 16, 256) if s in args.spps)} spp, then the reference): "
        "`docs/denoising-images.png`.", ""]
    out = ROOT / "docs" / "denoising-report.md"
    out.write_text("\n".join(header + lines))
    print(f"wrote {out.relative_to(ROOT)}, docs/denoising-plot.png, docs/denoising-images.png")


if __name__ == "__main__":
    main()
