"""Scene start-up at scale against Mitsuba 3: whole-process seconds and peak memory (max RSS) of
one render, clrender and Mitsuba 3 (llvm_ad_rgb) in fresh processes, interleaved, median of N.

    python tools/bench_startup.py [--triangles 1e6 3e6 1e7] [--runs 3] [--spp 4] [--resolution 256]
                                  [--scenes FILE.xml ...] [--renderers clrender mitsuba]
                                  [--baseline CHECKOUT]

Meshes: a noisy sphere (a latitude-longitude grid with the requested triangle count, its radius
displaced by waves and seeded noise), written as a binary PLY into a temporary folder with a
Mitsuba 3 XML scene (diffuse, a constant environment, 256 x 256 at 4 spp, path tracing to depth
8) that both renderers read. --scenes adds Mitsuba XML files as they are (e.g. Bitterli's
staircase, 775 OBJ files), their film set with -D resx/resy/spp where the file declares those
defaults.

Per run: whole-process wall seconds (as the user waits), peak resident memory (VmHWM, read by the
process at its end), and the phases each process reports: clrender: import, scene load (parse + mesh files),
scene arrays (gathering, BVH build, collapse), kernel build (cache warm after the warm-up run),
upload and the rest of set-up, render; Mitsuba: import + variant, load_file (parse, meshes,
Embree's BVH), render (JIT and kernel). Kernel caches of both are warm (one warm-up round).
--baseline: another checkout of clrender (e.g. `git worktree add /tmp/before main`) measured in
the same rounds as a third renderer, for before/after figures.
"""
import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from clrender.bench import interleaved, markdown_table, median, run_process  # noqa: E402

DEBIAN_LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"

CLRENDER_PROBE = """
import importlib, json, sys, time
start = time.perf_counter()
sys.path.insert(0, {root!r})
import clrender
render_module = importlib.import_module("clrender.render")   # clrender.render is the function
phases = {{"import": time.perf_counter() - start}}

def timed_phase(name, function):
    def wrapper(*args, **kwargs):
        begin = time.perf_counter()
        result = function(*args, **kwargs)
        phases[name] = phases.get(name, 0.0) + time.perf_counter() - begin
        return result
    return wrapper

render_module.build_scene_arrays = timed_phase("arrays", render_module.build_scene_arrays)
render_module.build_program = timed_phase("kernel", render_module.build_program)
begin = time.perf_counter()
scene = clrender.load_scene({scene!r}, {parameters!r})
phases["load"] = time.perf_counter() - begin
begin = time.perf_counter()
renderer = clrender.Renderer(scene, "cpu")
phases["upload"] = time.perf_counter() - begin - phases["arrays"] - phases["kernel"]
begin = time.perf_counter()
renderer.render(spp={spp})
phases["render"] = time.perf_counter() - begin
print(json.dumps(phases), {peak})
"""

MITSUBA_PROBE = """
import json, sys, time
start = time.perf_counter()
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
phases = {{"import": time.perf_counter() - start}}
begin = time.perf_counter()
scene = mi.load_file({scene!r}, **{parameters!r})
phases["load"] = time.perf_counter() - begin
begin = time.perf_counter()
image = mi.render(scene, spp={spp})
image.numpy()
phases["render"] = time.perf_counter() - begin
print(json.dumps(phases), {peak})
"""

PROBES = {"clrender": CLRENDER_PROBE, "mitsuba": MITSUBA_PROBE}
PHASES = {"clrender": ("import", "load", "arrays", "kernel", "upload", "render"),
          "mitsuba": ("import", "load", "render")}


# The probe's peak resident memory: VmHWM of its own address space. (ru_maxrss would also count
# the pages a forked child shares with this process before it starts Python.)
PEAK = "[int(line.split()[1]) for line in open('/proc/self/status') if line.startswith('VmHWM')][0]"


def run_probe(renderer, scene, parameters, spp, root=ROOT):
    """(wall seconds, peak RSS in MB, phases) of one fresh process rendering `scene` (clrender:
    the checkout `root`)."""
    code = PROBES[renderer].format(root=str(root), scene=str(scene), parameters=parameters, spp=spp, peak=PEAK)
    env = dict(os.environ)
    env.setdefault("DRJIT_LIBLLVM_PATH", DEBIAN_LLVM)
    run = run_process([sys.executable, "-c", code], env=env)
    phases, peak_kb = run.stdout.strip().splitlines()[-1].rsplit(" ", 1)
    return run.wall_seconds, int(peak_kb) / 1024, json.loads(phases)


def noisy_sphere(n_triangles, seed=0):
    """Vertices (V, 3) float32 and faces (F, 3) int32 of a latitude-longitude sphere of about
    n_triangles triangles (rows x 2 rows cells, two triangles each), radius displaced."""
    rows = max(2, round(np.sqrt(n_triangles / 4)))
    columns = 2 * rows
    theta, phi = np.meshgrid(np.linspace(0.01, np.pi - 0.01, rows + 1),
                             np.linspace(0, 2 * np.pi, columns, endpoint=False), indexing="ij")
    noise = np.random.default_rng(seed).standard_normal(theta.shape)
    radius = 1 + 0.02 * np.sin(37 * theta) * np.cos(23 * phi) + 0.005 * noise
    vertices = np.stack([radius * np.sin(theta) * np.cos(phi), radius * np.sin(theta) * np.sin(phi),
                         radius * np.cos(theta)], axis=-1).reshape(-1, 3).astype(np.float32)
    i, j = np.meshgrid(np.arange(rows), np.arange(columns), indexing="ij")
    a, b = i * columns + j, i * columns + (j + 1) % columns
    c, d = a + columns, b + columns
    faces = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3), np.stack([b, c, d], -1).reshape(-1, 3)])
    return vertices, faces.astype(np.int32)


def write_ply(path, vertices, faces):
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(vertices)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    rows = np.zeros(len(faces), np.dtype([("count", "u1"), ("indices", "<i4", (3,))]))
    rows["count"], rows["indices"] = 3, faces
    with open(path, "wb") as out:
        out.write(header.encode())
        out.write(vertices.astype("<f4").tobytes())
        out.write(rows.tobytes())


SCENE_XML = """<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="8"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, -4, 1" target="0, 0, 0" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>
    <film type="hdrfilm"><integer name="width" value="{size}"/><integer name="height" value="{size}"/></film>
  </sensor>
  <bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.6, 0.5, 0.4"/></bsdf>
  <shape type="ply"><string name="filename" value="{mesh}"/><ref id="grey"/></shape>
  <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>
"""


def mesh_scene(folder, n_triangles, spp, size):
    """(label, scene path, parameters) of a noisy sphere of about n_triangles in `folder`."""
    vertices, faces = noisy_sphere(n_triangles)
    mesh = Path(folder) / f"sphere_{len(faces)}.ply"
    write_ply(mesh, vertices, faces)
    scene = mesh.with_suffix(".xml")
    scene.write_text(SCENE_XML.format(spp=spp, size=size, mesh=mesh.name))
    return f"noisy sphere, {len(faces):,} triangles", scene, {}


def file_scene(path, spp, size):
    """(label, path, parameters): the film's defaults resx/resy/spp overridden where declared."""
    text = Path(path).read_text(errors="replace")
    parameters = {name: value for name, value in (("resx", size), ("resy", size), ("spp", spp))
                  if f'name="{name}"' in text}
    return Path(path).parent.name or Path(path).stem, Path(path), parameters


def summary(results, renderer):
    walls = [r[0] for r in results]
    rss = [r[1] for r in results]
    phases = {name: median([r[2].get(name, 0.0) for r in results]) for name in PHASES[renderer]}
    return median(walls), median(rss), phases


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--triangles", type=float, nargs="*", default=[1e6, 3e6, 1e7])
    parser.add_argument("--scenes", nargs="*", default=[])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--renderers", nargs="+", default=list(PROBES), choices=list(PROBES))
    parser.add_argument("--baseline", type=Path, help="another clrender checkout, measured as a third renderer")
    args = parser.parse_args()
    contenders = {renderer: (renderer, ROOT) for renderer in args.renderers}   # name: (probe, checkout)
    if args.baseline:
        contenders["baseline"] = ("clrender", args.baseline.resolve())
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        scenes = [lambda n=n: mesh_scene(folder, int(n), args.spp, args.resolution) for n in args.triangles]
        scenes += [lambda path=path: file_scene(path, args.spp, args.resolution) for path in args.scenes]
        for make_scene in scenes:   # each mesh written just before its runs
            label, scene, parameters = make_scene()
            runs = interleaved({name: (lambda probe=probe, root=root: run_probe(probe, scene, parameters, args.spp, root))
                                for name, (probe, root) in contenders.items()}, rounds=args.runs)
            measured = {name: summary(results, contenders[name][0]) for name, results in runs.items()}
            for name, (wall, rss, phases) in measured.items():
                detail = ", ".join(f"{phase} {seconds:.2f}" for phase, seconds in phases.items())
                print(f"{label}: {name} {wall:.2f} s, {rss:.0f} MB ({detail})", flush=True)
            if "clrender" in measured and "mitsuba" in measured:
                rows.append(table_row(label, measured))
    if rows:
        print(f"\nMedians of {args.runs} interleaved runs, fresh processes, {args.resolution} x {args.resolution} "
              f"at {args.spp} spp:\n")
        header = ["scene", "clrender", "Mitsuba 3", "time ratio", "clrender peak RSS", "Mitsuba peak RSS",
                  "memory ratio"]
        if args.baseline:
            header += ["baseline", "baseline time ratio", "baseline peak RSS", "baseline memory ratio"]
        print(markdown_table(header, rows))


def table_row(label, measured):
    """Seconds, peak RSS and their ratios to Mitsuba's, of clrender (and the baseline if run)."""
    wall_m, rss_m, _ = measured["mitsuba"]
    row = [label]
    for name in ("clrender", "baseline"):
        if name not in measured:
            continue
        wall, rss, _ = measured[name]
        row += [f"{wall:.2f} s", f"{wall_m:.2f} s", f"{wall / wall_m:.2f}", f"{rss:.0f} MB", f"{rss_m:.0f} MB",
                f"{rss / rss_m:.2f}"] if name == "clrender" else [
                f"{wall:.2f} s", f"{wall / wall_m:.2f}", f"{rss:.0f} MB", f"{rss / rss_m:.2f}"]
    return row


if __name__ == "__main__":
    main()
