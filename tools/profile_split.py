"""Where a real scene's render time goes, against Mitsuba 3's: `perf record` of one process per
renderer rendering the scene (mirrored as tools/peers.py does, the film's longer side --size),
and the CPU seconds of one render split into ray traversal and the rest of the kernel:

- clrender: the kernels' functions (PoCL's kernel libraries carry their symbols); traversal is
  the BVH walks and their per-lane wrappers (TRAVERSAL below), the rest every other function of
  the kernels (path loop, materials, lights, sampler, splatting).
- Mitsuba: Embree (libembree) against its JIT-compiled kernel (Dr.Jit's anonymous code).

Each process renders --renders + 1 images of --spp samples (the first also builds the kernels,
whose compilation is neither part; the set-up's kernels, such as the caustic guide's photons, are
in the rest); the split is per render. PoCL only (Intel's runtime and GPUs
run JIT code without symbols); the machine should be otherwise idle, and the ratios come from
one run. Needs Linux `perf`.

    python tools/profile_split.py ../shared/real-scenes/mitsuba-cbox ... [--size 256] [--spp 64]
                                  [--renders 3] [--variant llvm_ad_rgb] [--cache DIR]
"""
import argparse
import json
import re
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import real_scenes  # noqa: E402

import clrender  # noqa: E402
from clrender.bench import markdown_table  # noqa: E402

# clrender's traversal: the scalar walk, the packet walk, their box and leaf tests (triangles and
# spheres) and per-lane wrappers (kernels/bvh.h, bvh_packets.h, sphere.h, scene.h), whichever the
# compiler kept out of line.
TRAVERSAL = {"traverse_bvh", "traverse_bvh_packet", "ray_slabs", "intersect_boxes", "lane_bits", "lowest_bit", "min8",
             "max8", "nearer_hit", "intersect_leaf", "intersect_triangle_block", "intersect_triangle_block_lanes",
             "intersect_sphere", "intersect_sphere_leaf_lanes", "intersect_scene", "closest_hits",
             "closest_camera_hits", "occluder", "occluded", "occluders", "coherent_occluders", "shadow_blockers"}

# The Sobol sampler, as tools/peers.py times clrender; Mitsuba with the scenes' own sampler.
CHILD_CLRENDER = """
import json, sys, warnings, clrender
warnings.simplefilter("ignore")
xml, params, spp, renders = sys.argv[1], json.loads(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
renderer = clrender.Renderer(clrender.load_scene(xml, params), sampler="sobol")
for seed in range(renders + 1):
    renderer.render(spp=spp, seed=seed)
"""

CHILD_MITSUBA = """
import json, sys
import drjit as dr
import mitsuba as mi
mi.set_variant(sys.argv[5])
xml, params, spp, renders = sys.argv[1], json.loads(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
scene = mi.load_file(xml, **params)
for seed in range(renders + 1):
    dr.eval(mi.render(scene, spp=spp, seed=seed))
    dr.sync_thread()
"""

_ROW = re.compile(r"\s*(\d+)\s+(.*?)\s+\[[.k]\]\s+(\S+)")


def perf_samples(command, frequency):
    """Samples per DSO and symbol, {(dso, symbol): count}, of one run of `command` under
    `perf record` at `frequency` samples per second."""
    with tempfile.TemporaryDirectory() as scratch:
        data = Path(scratch) / "perf.data"
        subprocess.run(["perf", "record", "-q", "-F", str(frequency), "-o", str(data), "--", *command], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        report = subprocess.run(["perf", "report", "-i", str(data), "--stdio", "--sort", "dso,sym", "-F",
                                 "sample,dso,sym"], capture_output=True, text=True, check=True).stdout
    return report_counts(report)


def report_counts(report):
    """{(dso, symbol): samples} of `perf report --sort dso,sym -F sample,dso,sym` output (a DSO's
    name may hold spaces: Dr.Jit's code is "[JIT] tid N")."""
    counts = {}
    for line in report.splitlines():
        match = _ROW.match(line)
        if match and not line.lstrip().startswith("#"):
            key = (match.group(2), match.group(3))
            counts[key] = counts.get(key, 0) + int(match.group(1))
    return counts


def is_kernel_library(dso):
    """PoCL's compiled kernels: <kernel name>.so in its cache (system libraries are lib*.so*)."""
    return dso.endswith(".so") and not dso.startswith(("lib", "["))


def split_clrender(counts):
    """(traversal, rest) samples of clrender's kernels."""
    traversal = sum(n for (dso, sym), n in counts.items() if is_kernel_library(dso) and sym in TRAVERSAL)
    kernel = sum(n for (dso, sym), n in counts.items() if is_kernel_library(dso))
    return traversal, kernel - traversal


def split_mitsuba(counts):
    """(Embree, JIT kernel) samples of a Mitsuba process."""
    traversal = sum(n for (dso, _), n in counts.items() if dso.startswith("libembree"))
    jit = sum(n for (dso, _), n in counts.items() if dso.startswith("[JIT]"))
    return traversal, jit


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scenes", nargs="+", help="real scene folders or XML files (tools/real_scenes.py)")
    parser.add_argument("--size", type=int, default=256, help="the film's longer side")
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--renders", type=int, default=3)
    parser.add_argument("--variant", default="llvm_ad_rgb")
    parser.add_argument("--frequency", type=int, default=1000, help="perf's samples per second")
    parser.add_argument("--cache", type=Path, default=Path.home() / ".cache" / "clrender" / "profile-split")
    args = parser.parse_args()
    rows = []
    for xml in real_scenes.scene_files(args.scenes):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            resolution = clrender.load_scene(xml, real_scenes.parameters(xml)).camera.resolution
        size = real_scenes.film_size(resolution, args.size)
        name = real_scenes.scene_name(xml)
        mirrored = real_scenes.mirror(xml, args.cache / f"{name}-{size[0]}x{size[1]}", size, "independent")
        common = [str(mirrored), json.dumps(real_scenes.parameters(xml)), str(args.spp), str(args.renders)]
        ours = split_clrender(perf_samples([sys.executable, "-c", CHILD_CLRENDER, *common], args.frequency))
        theirs = split_mitsuba(perf_samples([sys.executable, "-c", CHILD_MITSUBA, *common, args.variant],
                                            args.frequency))
        per_render = args.frequency * (args.renders + 1)
        o_trav, o_rest, m_trav, m_rest = (n / per_render for n in (*ours, *theirs))
        rows.append([f"{name} ({size[0]}x{size[1]})", f"{o_trav:.2f}", f"{m_trav:.2f}", f"{o_trav / m_trav:.2f}",
                     f"{o_rest:.2f}", f"{m_rest:.2f}", f"{o_rest / m_rest:.2f}",
                     f"{(o_trav + o_rest) / (m_trav + m_rest):.2f}"])
        print(f"{name}: done", flush=True)
    print(f"\nCPU seconds per render of {args.spp} spp (perf samples at {args.frequency} Hz over {args.renders + 1} "
          f"renders); ratios clrender / Mitsuba ({args.variant}), above 1: clrender slower")
    print(markdown_table(["scene", "clrender traversal", "Embree", "ratio", "clrender rest", "Mitsuba rest",
                          "ratio", "render ratio"], rows))
    print(f"\n`python tools/profile_split.py {' '.join(args.scenes)} --size {args.size} --spp {args.spp} "
          f"--renders {args.renders}`")


if __name__ == "__main__":
    main()
