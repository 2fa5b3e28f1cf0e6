"""The noise of clrender's estimator against Mitsuba 3's on real scenes, at equal spp and without
timing: both renderers render --seeds images of --spp samples of each scene with the same
integrator and their independent samplers (or, with --mitsuba-sampler ldsampler
--clrender-sampler sobol, Mitsuba's low-discrepancy sampler against clrender's Sobol points;
tools/real_scenes.py mirrors the scene as tools/peers.py --real-scenes does), once per --filters
choice: `box` (every film's reconstruction filter replaced by the box, so every sample counts in
its own pixel in both renderers: the estimators alone) and `scene` (the scene's own filter).

    python tools/variance.py ../shared/real-scenes/ppg-torus ... [--size 64] [--spp 64] [--seeds 48]
                             [--filters box scene] [--clrender-sampler independent|sobol]
                             [--filter-method splat|importance] [--mitsuba-sampler independent|ldsampler]
    python tools/variance.py --test-scenes [NAME ...] --size 16 --spp 128 --seeds 16

With --test-scenes, the scenes of tests/mitsuba_scenes.py (test_mitsuba_parity.py's; their filter
is the box) instead: the variance of the estimators on small scenes of one feature each.

Per scene and filter, the mean over pixels and channels of the per-pixel variance of an --spp
image (across the seeds): both renderers are unbiased, so it is the expected MSE of one image
against the exact one. The ratio is clrender's over Mitsuba's (> 1: clrender is noisier), with
its jackknife standard error over the seeds (fireflies make the variances heavy-tailed: read it
as a rough error); robust to fireflies, the ratio of the mean variances over the 99 % of the
pixel values (pixel and channel) whose variances, both renderers' summed, are the lowest, and the
ratio of the median pixels' variances.

"splat" is the factor by which splatting (Mitsuba's, and clrender's render.filter_method
"splat", the default: each sample weighs into every pixel within the filter's radius, divided by
the weights' sum) lowers a pixel's variance below filter importance sampling (clrender's
--filter-method importance, kernels/filter.h: each sample in its own pixel, drawn from the
pixel's filter), where radiance and its variance are locally constant: (int f)^2 / int f^2 per
axis, squared (2.25 for the tent of radius 1, 3.1 for the gaussian of stddev 0.5; 1 for the box).
"""
import argparse
import os
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

import real_scenes

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
DEBIAN_LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"


def render_clrender(xml, params, spp, seeds, sampler, filter_method=None):
    """`filter_method`: render.filter_method ("splat", "importance"; None: the scene's)."""
    import clrender

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = clrender.load_scene(xml, params)
        if filter_method is not None:
            scene.render.filter_method = filter_method
        renderer = clrender.Renderer(scene, sampler=sampler)
        return np.stack([renderer.render(spp=spp, seed=s).image[..., :3] for s in seeds]).astype(np.float64)


def render_mitsuba(xml, params, spp, seeds, variant):
    import mitsuba as mi

    mi.set_variant(variant)
    scene = mi.load_file(str(xml), **params)
    return np.stack([np.asarray(mi.render(scene, spp=spp, seed=s))[..., :3] for s in seeds]).astype(np.float64)


def pixel_variances(images):
    """Per pixel and channel, the variance of one image across the seeds (axis 0)."""
    return images.var(axis=0, ddof=1)


def scene_camera(xml, params):
    """The scene's camera as clrender reads it (its filter Mitsuba's default gaussian where the
    film has none)."""
    from clrender import load_scene

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_scene(xml, params).camera


def splat_factor(f):
    """(int f)^2 / int f^2 per axis, squared, for filter `f` (scene.Filter)."""
    from clrender import filters

    t = np.linspace(-filters.radius(f), filters.radius(f), 200001)
    values = filters.evaluate(f, t)
    return float((np.trapezoid(values, t) ** 2 / np.trapezoid(values ** 2, t)) ** 2)


def compare(xml, theirs_xml, params, choice, args):
    """The table's cells after the scene for the mirrored scene `xml` (Mitsuba's `theirs_xml`, the
    same with its sampler) and filter `choice`."""
    from clrender.metrics import variance_ratio

    seeds = range(args.first_seed, args.first_seed + args.seeds)
    ours = render_clrender(xml, params, args.spp, seeds, args.clrender_sampler, args.filter_method)
    theirs = render_mitsuba(theirs_xml, params, args.spp, seeds, args.variant)
    ratio, error = variance_ratio(ours, theirs)
    v_ours, v_theirs = pixel_variances(ours), pixel_variances(theirs)
    f = scene_camera(xml, params).filter
    calm = v_ours + v_theirs <= np.quantile(v_ours + v_theirs, 0.99)
    return [f.type if choice == "box" else f"scene's ({f.type})", f"{v_ours.mean():.3g}", f"{v_theirs.mean():.3g}",
            f"{ratio:.2f} ± {error:.2f}", f"{v_ours[calm].mean() / v_theirs[calm].mean():.2f}",
            f"{np.median(v_ours) / np.median(v_theirs):.2f}", f"{splat_factor(f):.2f}",
            f"{(ours.mean() / theirs.mean() - 1) * 100:+.1f} %"]


def real_scene_cases(paths, args, scratch):
    """(row label, mirrored XML, Mitsuba's (its sampler --mitsuba-sampler), -D parameters, filter
    choice) of each real scene and filter."""
    for xml in real_scenes.scene_files(paths):
        name, params = real_scenes.scene_name(xml), real_scenes.parameters(xml)
        size = real_scenes.film_size(scene_camera(xml, params).resolution, args.size)
        for choice in args.filters:
            rfilter = "box" if choice == "box" else None
            mirrors = {sampler: real_scenes.mirror(xml, Path(scratch) / f"{name}-{choice}-{sampler}", size, sampler,
                                                   rfilter=rfilter)
                       for sampler in {"independent", args.mitsuba_sampler}}
            yield (f"{name} ({size[0]}x{size[1]})", mirrors["independent"], mirrors[args.mitsuba_sampler], params,
                   choice)


def test_scene_cases(names, args, scratch):
    """The same for the scenes of tests/mitsuba_scenes.py (all where `names` is empty), square
    films of --size pixels, their own filter (the box)."""
    sys.path.insert(0, str(ROOT / "tests"))
    import mitsuba_scenes

    for name in names or sorted(mitsuba_scenes.SCENES):
        (Path(scratch) / name).mkdir()
        xml = mitsuba_scenes.write(Path(scratch) / name, name)
        yield f"{name} ({args.size}x{args.size})", xml, xml, {"res": str(args.size)}, "scene"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scenes", nargs="*", type=Path, help="Mitsuba XML scenes or their folders")
    parser.add_argument("--test-scenes", nargs="*", metavar="NAME",
                        help="instead, these scenes of tests/mitsuba_scenes.py (none named: all)")
    parser.add_argument("--size", type=int, default=64, help="the film's longer side (the aspect kept)")
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--seeds", type=int, default=48, help="images per renderer, scene and filter")
    parser.add_argument("--first-seed", type=int, default=1, help="their seeds: this one and the next")
    parser.add_argument("--filters", nargs="+", choices=("box", "scene"), default=["box", "scene"])
    parser.add_argument("--clrender-sampler", choices=("independent", "sobol"), default="independent")
    parser.add_argument("--variant", default="llvm_ad_rgb")
    parser.add_argument("--mitsuba-sampler", choices=("independent", "ldsampler"), default="independent",
                        help="Mitsuba's sampler on the real scenes (the test scenes keep their own)")
    parser.add_argument("--filter-method", choices=("splat", "importance"),
                        help="clrender's render.filter_method (default: the scene's, splat)")
    args = parser.parse_args()
    if args.test_scenes is not None and args.mitsuba_sampler != "independent":
        parser.error("--mitsuba-sampler applies to real scenes; the test scenes keep their own sampler")
    if Path(DEBIAN_LLVM).is_file():
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", DEBIAN_LLVM)
    from clrender.bench import markdown_table

    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        cases = (test_scene_cases(args.test_scenes, args, scratch) if args.test_scenes is not None
                 else real_scene_cases(args.scenes, args, scratch))
        for label, xml, theirs_xml, params, choice in cases:
            rows.append([label] + compare(xml, theirs_xml, params, choice, args))
            print(" | ".join(rows[-1]), flush=True)
    print(f"\n{args.spp} spp, {args.seeds} seeds ({args.first_seed}..{args.first_seed + args.seeds - 1}) per renderer; "
          f"clrender's sampler {args.clrender_sampler}, filter method {args.filter_method or 'splat'}, Mitsuba's "
          f"{args.mitsuba_sampler} ({args.variant}); variance: mean over pixels and channels of one image's per-pixel "
          f"variance across the seeds\n")
    print(markdown_table(["scene (size)", "filter", "clrender variance", "Mitsuba variance",
                          "clrender / Mitsuba", "(99 % of pixels)", "(median pixels)", "splat", "means"], rows))
    print(f"\n`python tools/variance.py {' '.join(sys.argv[1:])}`")


if __name__ == "__main__":
    main()
