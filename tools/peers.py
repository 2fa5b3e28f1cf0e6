"""clrender against Mitsuba 3, side by side in one run: efficiency 1 / (MSE x seconds) on the
benchmark scenes, each renderer timed whole in fresh processes, interleaved, median of N.

    python tools/peers.py [--scenes cornell_box glass_sphere ...] [--runs 3] [--spp 64]
                          [--reference-batches 8] [--cache DIR] [--variant llvm_ad_rgb]
                          [--sampler sobol|independent] [--mitsuba-samplers independent ldsampler ...]
    python tools/peers.py --real-scenes ../shared/real-scenes [--size 128] [--cold] [--baseline CHECKOUT] ...

For each scene (256 x 256, max depth 64, Russian roulette from depth 5):
  1. write it as our JSON scene and as a Mitsuba 3 scene (clrender/mitsuba_export.py);
  2. references: each renderer renders --reference-batches independent batches of --spp
     samples (cached under --cache, default ~/.cache/clrender/peers, keyed by the scene's
     content); the two must agree within their noise (the convergence check, printed) before
     anything is timed, and the reference is their mean;
  3. the clrender package byte-compiled (as pip installs it, and as Mitsuba's modules are), one
     warm-up process per renderer (kernel caches of both), then --runs rounds, each running
     both renderers once in fresh processes at --spp, seed = round: whole-process wall and CPU
     seconds, and the MSE of the image against the reference (less the reference's own noise).
Ratio = clrender's efficiency / Mitsuba's (> 1: clrender is better), from the median seconds
and the mean MSE; the CPU column uses CPU seconds (less sensitive to other load on the machine).
The timed runs use clrender's --sampler (default: the scene's, sobol) and each of Mitsuba's
--mitsuba-samplers (default independent; a column group each); references always use both
renderers' independent samplers (unbiased whatever the sampler; cached across samplers).

With --timing render (for GPUs, where start-up is most of a process and says nothing about
rendering): one process per renderer and scene renders a warm-up image (kernel builds, Mitsuba's
JIT), then --runs images back to back, each timed until it is on the host; the ratio uses the
median of those render times. Run it on the GPU's machine: clrender takes the first GPU (or
$CLRENDER_DEVICE), Mitsuba the --variant (cuda_ad_rgb).

With --timing traversal: no images. Rays with origins uniform in the scene's bounding box (its
middle 90 % per axis) and uniform directions (--rays of them, the same file for both) are traced
by both renderers in one process each: a closest hit and an any-hit (shadow) query per ray, a
warm-up launch, then --runs launches (median CPU seconds per ray). The two must find the same
hits (the fraction that agree is printed) before their times mean anything: clrender's BVH
traversal (kernels/bvh.h) against Mitsuba's (Embree on the CPU).

With --real-scenes PATH... (Mitsuba XML scenes as written by others, or a folder of them such as
../shared/real-scenes: tools/real_scenes.py): each scene as shipped, in a mirrored copy whose film
is resized (--size, the longer side; the aspect kept) and whose sampler is each of Mitsuba's
--mitsuba-samplers (clrender reads the `independent` copy and uses --sampler); research
integrators a scene names as its default become `-D integrator=path` (SOURCES.md). References,
convergence check and interleaving as above. Each process also times its phases (load, arrays +
BVH, kernel build, first render; Mitsuba: load_file, first render) and renders a second image of
another seed, which is rendering alone: the table gives the ratio whole process (less that second
render), by CPU seconds and by rendering alone, and a start-up table (warm caches; with --cold,
one more process per renderer and scene with empty kernel caches). --baseline CHECKOUT adds the
clrender of another checkout (the code before a change) to the same interleaved rounds, with its
own table. --timing traversal works on the real scenes too, and so does --timing render (the
GPU's table: render seconds and MSE per renderer, no start-up).

Mitsuba is an optional extra (`pip install -e '.[peers]'`). Its LLVM variants need an LLVM
shared library: DRJIT_LIBLLVM_PATH defaults to Debian's libllvm19 when that file exists.
"""
import argparse
import hashlib
import importlib.util
import json
import os
import sys
from pathlib import Path

import real_scenes

ROOT = Path(__file__).resolve().parent.parent
SCENES_DIR = ROOT / "scenes"
DEBIAN_LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
RENDERERS = ("clrender", "mitsuba")


# ---------------------------------------------------------------------------------------------
# The benchmark scenes: example scenes with the benchmark's settings
# ---------------------------------------------------------------------------------------------
def _example(name):
    data = json.loads((SCENES_DIR / f"{name}.json").read_text())
    for shape in data["shapes"]:   # mesh files: absolute, the scene is written elsewhere
        if "file" in shape:
            shape["file"] = str((SCENES_DIR / shape["file"]).resolve())
    return data


def _without(data, *names):
    data["shapes"] = [s for s in data["shapes"] if s.get("name") not in names]
    return data


def _smoke():
    data = _without(_example("smoke_cornell_box"))
    data["media"] = [{"name": "smoke", "sigma_t": 2.0, "albedo": 0.8, "g": 0.5}]
    return data


def _cloud():
    data = _example("cloud_cornell_box")
    cloud = data["media"][0]
    cloud["density"]["resolution"] = [64, 64, 64]   # noise_cloud peaks at density 1
    cloud.update(sigma_t=20.0, albedo=0.9)
    # Off the floor by a hair (both the grid and its boundary box): where two surfaces coincide,
    # which one a ray meets first is up to rounding, and the two renderers' answers differ.
    cloud["transform"]["translate"][1] += LIFT
    _lift(data, "cloud_bounds")
    return data


def _prism():
    return _lift(_example("tir_prism"), "prism")


# Shapes standing on the floor are lifted by this much (see _cloud).
LIFT = 1e-3


def _lift(data, name):
    shape = next(s for s in data["shapes"] if s.get("name") == name)
    translate = shape.setdefault("transform", {}).setdefault("translate", [0, 0, 0])
    translate[1] += LIFT
    return data


BENCHMARKS = {
    "cornell_box": ("Cornell box, two diffuse blocks", lambda: _example("cornell_box")),
    "glass_sphere": ("Cornell box, smooth glass sphere", lambda: _example("cornell_glass")),
    "tir_prism": ("Cornell box, glass prism with total internal reflection", _prism),
    "smoke": ("Cornell box, homogeneous smoke sphere (sigma_t 2, albedo 0.8, g 0.5)", _smoke),
    "cloud": ("Cornell box, 64^3 grid cloud (max density 20, albedo 0.9)", _cloud),
}


def benchmark_scene(name, spp, resolution=256, max_depth=64, rr_depth=5):
    """The scene dict (our JSON structure) of a benchmark, with the common settings."""
    data = BENCHMARKS[name][1]()
    data["camera"]["resolution"] = [resolution, resolution]
    data["render"].update(spp=spp, max_depth=max_depth, rr_depth=rr_depth, seed=0)
    return data


def prepare(name, data, cache):
    """The scene's folder in the cache, named by a hash of the scene: our scene.json, and the
    Mitsuba description mitsuba.json with its assets (rewritten every run, the exporter may
    have changed). Returns (folder, {renderer: a hash of what it renders}), which keys the
    references."""
    import numpy as np

    import clrender
    from clrender import mitsuba_export
    from clrender.arrays import build_scene_arrays
    from clrender.triangle_blocks import slot_triangles

    text = json.dumps(data, indent=1, sort_keys=True)
    # Named by the content, mesh files by theirs (not by where the checkout lies).
    named = json.loads(text)
    for shape in named["shapes"]:
        if "file" in shape:
            shape["file"] = hashlib.sha256(Path(shape["file"]).read_bytes()).hexdigest()
    digest = hashlib.sha256(json.dumps(named, sort_keys=True).encode()).hexdigest()[:12]
    folder = Path(cache) / f"{name}-{digest}"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "scene.json").write_text(text)
    scene = clrender.load_scene(folder / "scene.json")
    description = json.dumps(mitsuba_export.mitsuba_description(scene, folder / "assets"), indent=1)
    (folder / "mitsuba.json").write_text(description)
    digest = hashlib.sha256(description.replace(str(folder.resolve()), "").encode())
    for asset in sorted((folder / "assets").iterdir()):
        digest.update(asset.read_bytes())
    # Ours: the geometry, materials and media the kernel reads (the same scene file may load into
    # other geometry, as spheres did when they became analytic), not their BVH order.
    arrays = build_scene_arrays(scene)
    ours = hashlib.sha256()
    triangles = np.concatenate(slot_triangles(arrays.blocks, len(arrays.info)), axis=1)
    for per_slot in (triangles, arrays.spheres, arrays.shading, arrays.info, arrays.emitters):
        rows = np.ascontiguousarray(per_slot).view(f"V{per_slot.dtype.itemsize}")
        ours.update(np.sort(rows).tobytes())
    for name in ("materials", "media", "grid_data"):
        ours.update(getattr(arrays, name).tobytes())
    return folder, {"clrender": ours.hexdigest()[:12], "mitsuba": digest.hexdigest()[:12]}


# ---------------------------------------------------------------------------------------------
# The timed processes: each renders, writes the image, exits
# ---------------------------------------------------------------------------------------------
def child_clrender(folder, spp, seed, batches, out, sampler, warmup):
    import clrender

    renderer = clrender.Renderer(clrender.load_scene(folder / "scene.json"), sampler=sampler)
    _render_batches(lambda s: renderer.render(spp=spp, seed=s).image, seed, batches, out, warmup)


def _render_batches(render, seed, batches, out, warmup):
    """Images of seeds seed, seed + 1, ... written to `out` with each one's seconds beside it
    (`render(seed)` returns the image on the host); with `warmup`, one untimed render first."""
    import numpy as np

    from clrender.bench import timed

    if warmup:
        render(0)
    seconds, images = zip(*(timed(lambda: render(seed + b)) for b in range(batches)))
    _write(out, np.stack(images), seconds)


def child_mitsuba(folder, spp, seed, batches, out, variant, sampler, warmup):
    import mitsuba as mi
    import numpy as np

    mi.set_variant(variant)
    # By file path: importing the clrender package would add pyopencl to Mitsuba's process.
    spec = importlib.util.spec_from_file_location("mitsuba_export", ROOT / "clrender" / "mitsuba_export.py")
    export = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(export)
    description = json.loads((folder / "mitsuba.json").read_text())
    description["sensor"]["sampler"]["type"] = sampler
    scene = mi.load_dict(export.to_mitsuba_dict(description, mi))
    _render_batches(lambda s: np.asarray(mi.render(scene, spp=spp, seed=s), np.float32)[..., :3],
                    seed, batches, out, warmup)


def _clrender_scene(source):
    """A benchmark's folder (its scene.json), or a real scene: (XML path, -D parameters)."""
    import warnings

    import clrender

    if isinstance(source, tuple):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return clrender.load_scene(*source)
    return clrender.load_scene(source / "scene.json")


def _mitsuba_scene(source, mi):
    """The same for Mitsuba (load_file, or the exported benchmark)."""
    if isinstance(source, tuple):
        return mi.load_file(str(source[0]), **source[1])
    spec = importlib.util.spec_from_file_location("mitsuba_export", ROOT / "clrender" / "mitsuba_export.py")
    export = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(export)
    return mi.load_dict(export.to_mitsuba_dict(json.loads((source / "mitsuba.json").read_text()), mi))


def child_traversal_clrender(folder, rays_path, runs, out):
    """Hit distances of the rays in rays_path ((N, 2, 3): origins, directions) by clrender's
    traversal kernel (the tests' trace_rays), and the CPU seconds of each timed launch."""
    import numpy as np
    import pyopencl as cl

    import clrender
    from clrender.arrays import build_scene_arrays
    from clrender.device import build_program
    from clrender.features import FEATURE_VALUES

    rays = np.load(rays_path)
    arrays = build_scene_arrays(_clrender_scene(folder))
    origins = np.zeros((len(rays), 4), np.float32)
    directions = np.zeros((len(rays), 4), np.float32)
    origins[:, :3] = rays[:, 0] * arrays.length_scale
    directions[:, :3] = rays[:, 1]
    context = cl.Context([clrender.choose_device()])
    queue = cl.CommandQueue(context)
    no_features = {name: values[0] for name, values in FEATURE_VALUES.items()}
    kernel = cl.Kernel(build_program(context, no_features, entry="tests.cl"), "trace_rays")
    flags = cl.mem_flags
    inputs = [cl.Buffer(context, flags.READ_ONLY | flags.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(x))
              for x in (arrays.nodes, arrays.blocks, arrays.spheres, origins, directions)]
    outputs = [cl.Buffer(context, flags.WRITE_ONLY, 4 * len(rays)) for _ in range(3)]

    def launch():
        kernel(queue, (len(rays),), None, *inputs, *outputs).wait()
    seconds = _cpu_seconds_of_runs(launch, runs)
    t = np.empty(len(rays), np.float32)
    cl.enqueue_copy(queue, t, outputs[0])
    _write_traversal(out, t / arrays.length_scale, seconds)


def child_traversal_mitsuba(folder, rays_path, runs, out, variant):
    """The same with Mitsuba's ray_intersect_preliminary and ray_test."""
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    mi.set_variant(variant)
    scene = _mitsuba_scene(folder, mi)
    rays = np.load(rays_path).astype(np.float32)
    ray = mi.Ray3f(mi.Point3f(np.ascontiguousarray(rays[:, 0].T)), mi.Vector3f(np.ascontiguousarray(rays[:, 1].T)))
    dr.eval(ray)
    hits = []

    def launch():
        nearest = scene.ray_intersect_preliminary(ray)
        blocked = scene.ray_test(ray)
        dr.eval(nearest.t, blocked)
        dr.sync_thread()
        hits[:] = [nearest.t]
    seconds = _cpu_seconds_of_runs(launch, runs)
    _write_traversal(out, np.array(hits[0], np.float32), seconds)


def _cpu_seconds_of_runs(launch, runs):
    """CPU seconds (all threads) of each of `runs` calls of `launch`, after one untimed call."""
    launch()
    seconds = []
    for _ in range(runs):
        before = os.times()
        launch()
        after = os.times()
        seconds.append((after.user - before.user) + (after.system - before.system))
    return seconds


def _write_traversal(out, t, seconds):
    import numpy as np

    np.save(out, np.where(np.isfinite(t), t, np.inf).astype(np.float32))
    Path(out).with_suffix(".seconds.json").write_text(json.dumps(seconds))


def _write(out, images, seconds):
    import numpy as np

    np.save(out, images[..., :3].astype(np.float32))
    Path(out).with_suffix(".seconds.json").write_text(json.dumps(list(seconds)))


def child_command(renderer, folder, spp, seed, out, variant, batches=1, sampler="independent", warmup=False):
    """The process rendering `batches` images; `sampler`: the renderer's name for its sampler."""
    return ([sys.executable, str(Path(__file__).resolve()), "--child", renderer, str(folder), str(spp),
             str(seed), str(batches), str(out), "--variant", variant, "--child-sampler", sampler]
            + (["--child-warmup"] if warmup else []))


def byte_compile_clrender():
    """Byte-compile the clrender package (__pycache__, ignored by git), as pip does at install:
    Mitsuba's modules come compiled, while a checkout run under PYTHONDONTWRITEBYTECODE (as on
    this project's machines) would compile ours again in every timed process (50-60 ms)."""
    import compileall

    compileall.compile_dir(ROOT / "clrender", quiet=1)


def child_environment():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    if "DRJIT_LIBLLVM_PATH" not in env and Path(DEBIAN_LLVM).is_file():
        env["DRJIT_LIBLLVM_PATH"] = DEBIAN_LLVM
    return env


# ---------------------------------------------------------------------------------------------
# References and the convergence check
# ---------------------------------------------------------------------------------------------
def reference_batches(renderer, folder, spp, batches, variant, key, command=child_command):
    """(batches, H, W, 3) images of independent seeds, cached in the scene's folder under `key`
    (a hash of what the renderer renders). Kernel changes are not in the key: --fresh renders
    them again. `command`: the child's command line, as child_command's."""
    import numpy as np

    from clrender.bench import run_process

    path = folder / f"reference-{renderer}-{key}-{spp}spp-{batches}.npy"
    if not path.is_file():
        timing = run_process(command(renderer, folder, spp, 1000, path, variant, batches), env=child_environment())
        print(f"  reference {renderer}: {batches} x {spp} spp in {timing.wall_seconds:.0f} s", flush=True)
    return np.load(path)


def block_means(images, size=8):
    """Means over size x size pixel blocks of (..., H, W, 3) images (H, W multiples of size)."""
    *lead, h, w, c = images.shape
    return images.reshape(*lead, h // size, size, w // size, size, c).mean(axis=(-4, -2))


def joint_reference(batches):
    """Both renderers' reference batches -> ((their mean, the variance of that mean averaged over
    the pixels), their agreement), printed. The reference's own noise adds to every MSE against it."""
    import numpy as np

    check = agreement(batches["clrender"], batches["mitsuba"])
    both = np.concatenate([batches["clrender"], batches["mitsuba"]])
    print(f"  convergence: difference / noise = {check['pixels']:.2f} per pixel, {check['blocks']:.2f} per 8x8 "
          f"block; image means differ by {100 * check['mean']:+.2f} %", flush=True)
    return (both.mean(axis=0), float(np.mean(both.var(axis=0, ddof=1) / len(both)))), check


def agreement(a, b):
    """How two sets of batch images agree: mean squared difference of their means over its
    expectation from their noise (1: equal expectations), per pixel and per 8x8 block (where
    noise averages out and a bias does not), and the relative difference of the image means."""
    import numpy as np

    out = {}
    for label, (x, y) in (("pixels", (a, b)), ("blocks", (block_means(a), block_means(b)))):
        noise = x.var(axis=0, ddof=1) / len(x) + y.var(axis=0, ddof=1) / len(y)
        out[label] = float(np.mean((x.mean(axis=0) - y.mean(axis=0)) ** 2) / np.mean(noise))
    out["mean"] = float(a.mean() / b.mean() - 1)
    return out


# ---------------------------------------------------------------------------------------------
# The run
# ---------------------------------------------------------------------------------------------
def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenes", nargs="+", choices=list(BENCHMARKS), default=list(BENCHMARKS))
    parser.add_argument("--runs", type=int, default=3, help="timed rounds (median)")
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--reference-batches", type=int, default=8,
                        help="batches of --spp samples per renderer for the reference")
    parser.add_argument("--cache", type=Path, default=Path.home() / ".cache" / "clrender" / "peers")
    parser.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant")
    parser.add_argument("--check-only", action="store_true", help="references and convergence check, no timing")
    parser.add_argument("--fresh", action="store_true", help="render the references again")
    parser.add_argument("--sampler", choices=("sobol", "independent"), default="sobol",
                        help="clrender's sampler in the timed runs")
    parser.add_argument("--mitsuba-samplers", nargs="+", default=["independent"],
                        choices=("independent", "stratified", "multijitter", "orthogonal", "ldsampler"),
                        help="Mitsuba's samplers in the timed runs, a column group each")
    parser.add_argument("--timing", choices=("process", "render", "traversal"), default="process",
                        help="time whole fresh processes, renders after a warm-up (GPUs), or ray traversal alone")
    parser.add_argument("--rays", type=int, default=1 << 21, help="rays per launch with --timing traversal")
    parser.add_argument("--real-scenes", nargs="+", type=Path, metavar="PATH",
                        help="Mitsuba XML scenes, or folders of them (../shared/real-scenes), instead of --scenes")
    parser.add_argument("--size", type=int, default=128, help="--real-scenes: the film's longer side")
    parser.add_argument("--baseline", type=Path, metavar="CHECKOUT",
                        help="--real-scenes: also time the clrender of another checkout (before a change), interleaved")
    parser.add_argument("--cold", action="store_true",
                        help="--real-scenes: also one process per renderer and scene with empty kernel caches")
    parser.add_argument("--child-sampler", help=argparse.SUPPRESS)
    parser.add_argument("--child-params", default="{}", help=argparse.SUPPRESS)
    parser.add_argument("--child-real", nargs=7, help=argparse.SUPPRESS,
                        metavar=("RENDERER", "XML", "PARAMETERS", "SPP", "SEED", "BATCHES", "OUT"))
    parser.add_argument("--child-warmup", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--child", nargs=6, metavar=("RENDERER", "FOLDER", "SPP", "SEED", "BATCHES", "OUT"),
                        help=argparse.SUPPRESS)
    parser.add_argument("--child-traversal", nargs=4, metavar=("RENDERER", "FOLDER", "RAYS", "OUT"),
                        help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child_traversal:
        renderer, folder, rays, out = args.child_traversal
        folder = (Path(folder), json.loads(args.child_params)) if folder.endswith(".xml") else Path(folder)
        if renderer == "clrender":
            child_traversal_clrender(folder, rays, args.runs, out)
        else:
            child_traversal_mitsuba(folder, rays, args.runs, out, args.variant)
        return
    if args.child_real:
        renderer, xml, params, spp, seed, batches, out = args.child_real
        child = (real_scenes.child_clrender if renderer == "clrender" else real_scenes.child_mitsuba)
        child(Path(xml), json.loads(params), int(spp), int(seed), int(batches), out,
              args.child_sampler if renderer == "clrender" else args.variant, args.child_warmup)
        return
    if args.child:
        renderer, folder, spp, seed, batches, out = args.child
        if renderer == "clrender":
            child_clrender(Path(folder), int(spp), int(seed), int(batches), out, args.child_sampler,
                           args.child_warmup)
        else:
            child_mitsuba(Path(folder), int(spp), int(seed), int(batches), out, args.variant, args.child_sampler,
                          args.child_warmup)
        return
    run(args)


def run(args):
    import tempfile

    import clrender
    from clrender.bench import interleaved, machine_description

    command = "python tools/peers.py " + " ".join(sys.argv[1:])
    env = child_environment()
    byte_compile_clrender()
    print(f"command: {command}")
    print(f"machine: {machine_description()}; OpenCL: {clrender.choose_device().name.strip()} "
          f"({clrender.choose_device().platform.version.strip()}); Mitsuba {_mitsuba_version(env)} {args.variant}")
    folders, references, checks = {}, {}, {}
    if args.timing == "traversal":
        run_traversal(args, env, command)
        return
    if args.real_scenes:
        run_real(args, env, command)
        return
    for name in args.scenes:
        folders[name], keys = prepare(name, benchmark_scene(name, args.spp), args.cache)
        print(f"{name}: {folders[name]}", flush=True)
        if args.fresh:
            for old in folders[name].glob("reference-*.npy"):
                old.unlink()
        batches = {r: reference_batches(r, folders[name], args.spp, args.reference_batches, args.variant,
                                        keys[r]) for r in RENDERERS}
        references[name], checks[name] = joint_reference(batches)
    if args.check_only:
        return
    with tempfile.TemporaryDirectory() as scratch:
        seeds = iter(range(1, 10 ** 6))
        runners = [("clrender", args.sampler)] + [("mitsuba", m) for m in args.mitsuba_samplers]
        if args.timing == "render":
            results = {(name, runner): _render_timings(*runner, folders[name], args.spp, args.runs, scratch,
                                                       args.variant, env, references[name])
                       for name in args.scenes for runner in runners}
        else:
            measures = {(name, runner): _measure(*runner, folders[name], args.spp, seeds, scratch, args.variant,
                                                 env, references[name])
                        for name in args.scenes for runner in runners}
            results = interleaved(measures, rounds=args.runs, warmup=1)
    processes = args.timing == "process"
    timing = (f"median of {args.runs} fresh processes each, interleaved" if processes else
              f"median of {args.runs} renders after a warm-up render, in one process per renderer and scene")
    print(f"\n{args.spp} spp, max depth 64, roulette from depth 5; {timing}; MSE: mean over the runs (seeds) "
          f"against the mean of both {args.reference_batches} x {args.spp}-spp references, less their noise; "
          f"± the ratio's relative standard error from the spread of the runs' MSEs; clrender sampler {args.sampler}")
    print(_ratio_table({name: BENCHMARKS[name][0] for name in args.scenes}, "scene (256x256)", results, runners,
                       checks, processes))
    print(f"\n`{command}`")


def _ratio_table(labels, label_header, results, runners, checks, processes):
    """The Markdown table of clrender (runners[0]) against each of Mitsuba's runners: median
    seconds, mean MSE and the efficiency ratio per scene; `results[(name, runner)]`: (wall s, CPU s
    or None, MSE) per run."""
    import numpy as np

    from clrender.bench import markdown_table, median

    rows = []
    for name, label in labels.items():
        stats = {}
        for runner in runners:
            runs = results[(name, runner)]
            mses = [r[2] for r in runs]
            stats[runner] = (median([r[0] for r in runs]), median([r[1] for r in runs]) if processes else None,
                             float(np.mean(mses)), relative_standard_error(mses))
        cw, cc, cm, c_error = stats[runners[0]]
        row = [label, f"{cw:.4g}", f"{cm:.3g}"]
        for runner in runners[1:]:
            mw, mc, mm, m_error = stats[runner]
            # Mean MSEs of a few seeds are the noisy part of a ratio (the medians of time vary by a
            # few percent): its relative standard error from theirs.
            error = np.hypot(c_error, m_error)
            row += [f"{mw:.4g}", f"{mm:.3g}", f"{(mm * mw) / (cm * cw):.2f} ± {100 * error:.0f} %"]
            row += [f"{(mm * mc) / (cm * cc):.2f}"] if processes else []
        rows.append(row + [f"{checks[name]['blocks']:.2f}"])
    header = [label_header, "clrender s", "clrender MSE"]
    for _, sampler in runners[1:]:
        header += [f"Mitsuba {sampler} s", f"Mitsuba {sampler} MSE", f"ratio vs {sampler}"]
        header += ["ratio (CPU s)"] if processes else []
    return markdown_table(header + ["agreement"], rows)


# ---------------------------------------------------------------------------------------------
# Real scenes (--real-scenes): Mitsuba XML as shipped, phases timed in the processes
# ---------------------------------------------------------------------------------------------
def real_child_command(renderer, xml, params, spp, seed, out, variant, batches=1, sampler="independent",
                       warmup=False):
    """A process rendering a real scene (real_scenes.child_clrender or child_mitsuba); `sampler`:
    clrender's (Mitsuba's is the mirrored XML's); `warmup`: an untimed render first, then each
    render timed on its own (--timing render)."""
    return ([sys.executable, str(Path(__file__).resolve()), "--child-real", renderer, str(xml), json.dumps(params),
             str(spp), str(seed), str(batches), str(out), "--variant", variant, "--child-sampler", sampler]
            + (["--child-warmup"] if warmup else []))


def prepare_real(xml, size, mitsuba_samplers, cache):
    """(name, params, {sampler: mirrored XML}, key): the scene mirrored once per Mitsuba sampler
    (real_scenes.mirror) in the cache; `key` hashes the edited files and parameters, and keys the
    references of both renderers."""
    import warnings

    import clrender

    name, params = real_scenes.scene_name(xml), real_scenes.parameters(xml)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        resolution = clrender.load_scene(xml, params).camera.resolution
    width, height = real_scenes.film_size(resolution, size)
    folder = Path(cache) / f"real-{name}-{width}x{height}"
    mirrors = {sampler: real_scenes.mirror(xml, folder / sampler, (width, height), sampler)
               for sampler in {"independent", *mitsuba_samplers}}
    digest = hashlib.sha256(json.dumps(params, sort_keys=True).encode())
    for edited in sorted((folder / "independent").rglob("*.xml")):
        digest.update(edited.read_bytes() if not edited.is_symlink() else str(edited.resolve()).encode())
    return name, params, mirrors, f"{width}x{height}", digest.hexdigest()[:12]


def run_real(args, env, command):
    """--real-scenes: the efficiency table (whole process, CPU, render alone) and the start-up
    table (median phases; cold with --cold)."""
    import tempfile

    from clrender.bench import interleaved, markdown_table

    scenes, references, checks = {}, {}, {}
    for xml in real_scenes.scene_files(args.real_scenes):
        name, params, mirrors, size, key = prepare_real(xml, args.size, args.mitsuba_samplers, args.cache)
        scenes[name] = (params, mirrors, size)
        print(f"{name} ({size}, -D {params or 'none'}): {mirrors['independent']}", flush=True)

        def reference_command(renderer, _folder, spp, seed, out, variant, batches, _m=mirrors, _p=params):
            return real_child_command(renderer, _m["independent"], _p, spp, seed, out, variant, batches)
        batches = {}
        for renderer in RENDERERS:
            batches[renderer] = reference_batches(renderer, _real_folder(mirrors), args.spp, args.reference_batches,
                                                  args.variant, key, reference_command)
        references[name], checks[name] = joint_reference(batches)
    if args.check_only:
        return
    ours = [("clrender", args.sampler)] + ([("baseline", args.sampler)] if args.baseline else [])
    theirs = [("mitsuba", m) for m in args.mitsuba_samplers]
    runners = ours + theirs
    if args.timing == "render":
        run_real_renders(args, env, command, scenes, references, checks, ours[:1] + theirs)
        return
    baseline_env = {**env, "PYTHONPATH": os.pathsep.join(filter(None, [str(args.baseline), os.environ.get("PYTHONPATH")]))}
    with tempfile.TemporaryDirectory() as scratch:
        seeds = iter(range(1, 10 ** 6, 2))   # odd: each process also renders seed + 1
        measures = {(name, runner): _measure_real(*runner, *scenes[name][:2], args.spp, seeds, scratch, args.variant,
                                                  baseline_env if runner[0] == "baseline" else env, references[name])
                    for name in scenes for runner in runners}
        results = interleaved(measures, rounds=args.runs, warmup=1,
                              after_round=lambda number, _: print(f"round {number} done", flush=True))
        cold = ({key: measure(cold=True) for key, measure in measures.items() if key[1][0] != "baseline"}
                if args.cold else {})
    stats = {key: _real_stats(runs) for key, runs in results.items()}
    print(f"\n{args.spp} spp, the scenes' own max depth and integrator; median of {args.runs} fresh processes each, "
          f"interleaved; s: whole process, render s: a second render in the same process (rendering alone); MSE "
          f"against the mean of both {args.reference_batches} x {args.spp}-spp references, less their noise; "
          f"ratio > 1: clrender more efficient (± from the runs' MSEs); clrender sampler {args.sampler}")
    for runner in ours:
        print(f"\n{'clrender' if runner[0] == 'clrender' else f'clrender at {args.baseline}'}:")
        print(_efficiency_table(scenes, stats, runner, theirs, checks))
    startup = [[name] + _startup_cells(stats[(name, ours[0])], stats[(name, theirs[0])],
                                       cold.get((name, ours[0])), cold.get((name, theirs[0]))) for name in scenes]
    print("\nStart-up, median seconds (warm caches" + (", and cold: empty kernel caches, one process" if cold else "")
          + "); kernel: clrender's program build plus PoCL's first-launch compile, Mitsuba's JIT (first render less "
          "the second)")
    print(markdown_table(_STARTUP_HEADER + (_COLD_HEADER if cold else []), startup))
    print(f"\n`{command}`")


def run_real_renders(args, env, command, scenes, references, checks, runners):
    """--real-scenes with --timing render (GPUs): one process per renderer and scene renders a
    warm-up image, then --runs images each timed until it is on the host; the table of ratios."""
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        results = {}
        for name, (params, mirrors, _size) in scenes.items():
            for renderer, sampler in runners:
                out = Path(scratch) / f"{renderer}-{sampler}-{name}.npy"
                xml = mirrors["independent" if renderer == "clrender" else sampler]
                argv = real_child_command(renderer, xml, params, args.spp, 1, out, args.variant, args.runs,
                                          sampler if renderer == "clrender" else "independent", warmup=True)
                results[(name, (renderer, sampler))] = _timed_renders(argv, out, env, references[name])
            print(f"{name} done", flush=True)
    print(f"\n{args.spp} spp, the scenes' own max depth and integrator; median of {args.runs} renders after a "
          f"warm-up render, in one process per renderer and scene, each timed until the image is on the host; MSE: "
          f"mean over the runs (seeds) against the mean of both {args.reference_batches} x {args.spp}-spp "
          f"references, less their noise; ± from the spread of the runs' MSEs; clrender sampler {args.sampler}")
    labels = {name: f"{name} ({size})" for name, (_params, _mirrors, size) in scenes.items()}
    print(_ratio_table(labels, "scene (size)", results, runners, checks, processes=False))
    print(f"\n`{command}`")


def _efficiency_table(scenes, stats, ours, theirs, checks):
    """The Markdown table of one clrender runner's efficiency against each of Mitsuba's."""
    import numpy as np

    from clrender.bench import markdown_table

    rows = []
    for name in scenes:
        a = stats[(name, ours)]
        row = [f"{name} ({scenes[name][2]})", f"{a['wall']:.3g}", f"{a['render']:.3g}", f"{a['mse']:.3g}"]
        for runner in theirs:
            b = stats[(name, runner)]
            ratio = {k: (b["mse"] * b[k]) / (a["mse"] * a[k]) for k in ("wall", "cpu", "render")}
            row += [f"{b['wall']:.3g}", f"{b['render']:.3g}", f"{b['mse']:.3g}",
                    f"{ratio['wall']:.2f} ± {100 * np.hypot(a['error'], b['error']):.0f} %", f"{ratio['cpu']:.2f}",
                    f"{ratio['render']:.2f}"]
        rows.append(row + [f"{checks[name]['blocks']:.2f}", f"{100 * checks[name]['mean']:+.1f} %"])
    header = ["scene (size)", "clrender s", "render s", "MSE"]
    for _, sampler in theirs:
        header += [f"Mitsuba {sampler} s", "render s", "MSE", f"ratio vs {sampler}", "(CPU s)", "(render)"]
    return markdown_table(header + ["agreement", "means"], rows)


_STARTUP_HEADER = ["scene", "clrender load", "arrays + BVH", "kernel", "upload etc.", "Mitsuba load", "Mitsuba JIT"]
_COLD_HEADER = ["clrender kernel cold", "Mitsuba JIT cold"]


def _real_folder(mirrors):
    """The scene's folder in the cache (references live there): the mirrors' parent."""
    independent = mirrors["independent"]
    return next(p for p in independent.parents if p.name.startswith("real-"))


def _real_stats(runs):
    """Medians of a scene's runs (wall, CPU, render alone, phases) and the mean MSE."""
    import numpy as np

    from clrender.bench import median

    phases = {k: median([r["phases"].get(k, 0.0) for r in runs]) for k in runs[0]["phases"]}
    mses = [r["mse"] for r in runs]
    return {"wall": median([r["wall"] for r in runs]), "cpu": median([r["cpu"] for r in runs]),
            "render": phases["again"], "mse": float(np.mean(mses)), "error": relative_standard_error(mses),
            "phases": phases}


def _startup_cells(ours, theirs, ours_cold, theirs_cold):
    p, q = ours["phases"], theirs["phases"]
    kernel = p["kernel build"] + p["render"] - p["again"]
    cells = [p["load"], p["arrays + BVH"], kernel, p["set-up"] - p["arrays + BVH"] - p["kernel build"],
             q["load"], q["render"] - q["again"]]
    if ours_cold is not None:
        pc, qc = ours_cold["phases"], theirs_cold["phases"]
        cells += [pc["kernel build"] + pc["render"] - pc["again"], qc["render"] - qc["again"]]
    return [f"{c:.2f}" for c in cells]


def _measure_real(renderer, sampler, params, mirrors, spp, seeds, scratch, variant, env, reference):
    """A function running one timed process of a real scene: {wall, cpu, mse, phases}, the wall
    and CPU seconds less the second render's (real_scenes._render_all). With cold=True, the
    process runs with empty kernel caches (its own HOME, XDG cache, clrender and PoCL caches)."""
    import tempfile

    import numpy as np

    from clrender.bench import run_process

    child = "mitsuba" if renderer == "mitsuba" else "clrender"   # baseline: clrender of another checkout
    xml = mirrors["independent" if child == "clrender" else sampler]

    def measure(cold=False):
        seed = next(seeds)
        out = Path(scratch) / f"{renderer}-{seed}.npy"
        argv = real_child_command(child, xml, params, spp, seed, out, variant,
                                  sampler=sampler if child == "clrender" else "independent")
        with tempfile.TemporaryDirectory(dir=scratch) as empty:
            cold_env = {"HOME": empty, "XDG_CACHE_HOME": empty, "CLRENDER_CACHE_DIR": empty, "POCL_CACHE_DIR": empty}
            timing = run_process(argv, env={**env, **cold_env} if cold else env)
        phases = json.loads(out.with_suffix(".phases.json").read_text())
        return {"wall": timing.wall_seconds - phases["again"], "cpu": timing.cpu_seconds - phases["again cpu"],
                "mse": _mse(np.load(out)[0], reference), "phases": phases}
    return measure


def run_traversal(args, env, command):
    """--timing traversal: the table of CPU nanoseconds per ray (closest hit and any hit)."""
    import tempfile

    import numpy as np

    from clrender.bench import markdown_table, median, run_process

    rows = []
    if args.real_scenes:
        sources = {real_scenes.scene_name(xml): (xml, real_scenes.parameters(xml))
                   for xml in real_scenes.scene_files(args.real_scenes)}
    else:
        sources = {name: prepare(name, benchmark_scene(name, args.spp), args.cache)[0] for name in args.scenes}
    with tempfile.TemporaryDirectory() as scratch:
        for name, source in sources.items():
            rays_path = Path(scratch) / f"{name}-rays.npy"
            np.save(rays_path, random_rays(_clrender_scene(source), args.rays))
            results = {}
            for renderer in RENDERERS:
                out = Path(scratch) / f"{name}-{renderer}.npy"
                where, params = source if isinstance(source, tuple) else (source, {})
                run_process([sys.executable, str(Path(__file__).resolve()), "--child-traversal", renderer,
                             str(where), str(rays_path), str(out), "--runs", str(args.runs),
                             "--variant", args.variant, "--child-params", json.dumps(params)], env=env)
                seconds = json.loads(out.with_suffix(".seconds.json").read_text())
                results[renderer] = (np.load(out), median(seconds) / args.rays * 1e9)
            (t_ours, ns_ours), (t_theirs, ns_theirs) = results["clrender"], results["mitsuba"]
            same = hits_agree(t_ours, t_theirs)
            rows.append([BENCHMARKS[name][0] if name in BENCHMARKS else name, f"{ns_ours:.1f}", f"{ns_theirs:.1f}", f"{ns_theirs / ns_ours:.2f}",
                         f"{100 * np.mean(~np.isfinite(t_ours)):.1f} %", f"{100 * same:.3f} %"])
            print(f"{name}: done", flush=True)
    print(f"\n{args.rays} rays per launch; CPU ns per ray (a closest hit and an any hit), median of {args.runs} "
          f"launches after a warm-up; ratio > 1: clrender faster; agree: rays whose nearest hit both find at "
          f"the same distance (relative 1e-4) or both miss")
    print(markdown_table(["scene", "clrender ns", "Mitsuba ns", "ratio", "misses", "agree"], rows))
    print(f"\n`{command}`")


def random_rays(scene, count, seed=1):
    """(count, 2, 3) float32 rays: origins uniform in the middle 90 % of the bounding box of the
    scene's geometry along each axis, directions uniform on the sphere."""
    import numpy as np

    from clrender.arrays import build_scene_arrays

    arrays = build_scene_arrays(scene)
    root = arrays.nodes[0]   # the union of its children's boxes (empty lanes: lo +inf, hi -inf)
    low = np.array([root[f"lo_{axis}"][np.isfinite(root[f"lo_{axis}"])].min() for axis in "xyz"])
    high = np.array([root[f"hi_{axis}"][np.isfinite(root[f"hi_{axis}"])].max() for axis in "xyz"])
    low, high = low / arrays.length_scale, high / arrays.length_scale
    rng = np.random.default_rng(seed)
    origins = rng.uniform(low + 0.05 * (high - low), high - 0.05 * (high - low), (count, 3))
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return np.stack([origins, directions], axis=1).astype(np.float32)


def hits_agree(t_a, t_b):
    """Fraction of rays that both miss or both hit at the same distance (relative 1e-4)."""
    import numpy as np

    both_miss = ~np.isfinite(t_a) & ~np.isfinite(t_b)
    with np.errstate(invalid="ignore"):
        same = np.isfinite(t_a) & np.isfinite(t_b) & (np.abs(t_a - t_b) <= 1e-4 * np.maximum(t_a, t_b))
    return float(np.mean(both_miss | same))


def relative_standard_error(values):
    """Standard error of the mean of `values` over the mean (0 for a single value)."""
    import numpy as np

    if len(values) < 2:
        return 0.0
    return float(np.std(values, ddof=1) / np.sqrt(len(values)) / np.mean(values))


def _measure(renderer, sampler, folder, spp, seeds, scratch, variant, env, reference):
    """A function that runs one timed process and returns (wall s, CPU s, MSE)."""
    import numpy as np

    from clrender.bench import run_process

    def measure():
        seed = next(seeds)
        out = Path(scratch) / f"{renderer}-{seed}.npy"
        timing = run_process(child_command(renderer, folder, spp, seed, out, variant, sampler=sampler), env=env)
        return timing.wall_seconds, timing.cpu_seconds, _mse(np.load(out)[0], reference)
    return measure


def _render_timings(renderer, sampler, folder, spp, runs, scratch, variant, env, reference):
    """(render s, None, MSE) of `runs` renders (seeds 1, 2, ...) in one process, after a warm-up."""
    out = Path(scratch) / f"{renderer}-{sampler}-{folder.name}.npy"
    return _timed_renders(child_command(renderer, folder, spp, 1, out, variant, runs, sampler, warmup=True), out,
                          env, reference)


def _timed_renders(argv, out, env, reference):
    """Run the child `argv`, which writes its images to `out` and each one's seconds beside them:
    (render s, None, MSE) per image."""
    import numpy as np

    from clrender.bench import run_process

    run_process(argv, env=env)
    seconds = json.loads(out.with_suffix(".seconds.json").read_text())
    return [(s, None, _mse(image, reference)) for s, image in zip(seconds, np.load(out))]


def _mse(image, reference):
    """MSE of `image` against reference = (mean image, its noise), less that noise."""
    import numpy as np

    return float(np.mean((image - reference[0]) ** 2)) - reference[1]


def _mitsuba_version(env):
    from clrender.bench import run_process

    try:
        return run_process([sys.executable, "-c", "import mitsuba; print(mitsuba.__version__)"], env=env).stdout.strip()
    except RuntimeError:
        sys.exit("peers.py: Mitsuba 3 is not installed (pip install -e '.[peers]')")


if __name__ == "__main__":
    main()
