"""Where a real scene's render time goes, against Mitsuba 3's: `perf record` of one process per
renderer rendering the scene, and the CPU seconds of one render split into ray traversal and the
rest of the kernel:

- clrender: the kernels' functions (PoCL's kernel libraries carry their symbols); traversal is
  the BVH walks and their per-lane wrappers (TRAVERSAL below), the rest every other function of
  the kernels (path loop, materials, lights, sampler, splatting).
- Mitsuba: Embree (libembree) against its JIT-compiled kernel (Dr.Jit's anonymous code).

The processes are tools/peers.py's real-scene children on the scene as peers.py mirrors it (the
film's longer side --size, in peers.py's cache): a warm-up render, then --renders renders of
--spp samples. Kernel compilation is neither part; the set-up's kernels (the caustic guide's
photons) are in the rest; the split is per render, over all --renders + 1. PoCL only (Intel's
runtime and GPUs run JIT code without symbols); the machine should be otherwise idle, and the
ratios come from one run. Needs Linux `perf`.

    python tools/profile_split.py ../shared/real-scenes/mitsuba-cbox ... [--size 256] [--spp 64]
                                  [--renders 3] [--variant llvm_ad_rgb] [--cache DIR]
"""
import argparse
import re
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import peers  # noqa: E402
import real_scenes  # noqa: E402

from clrender.bench import markdown_table  # noqa: E402

# clrender's traversal: the scalar walk, the packet walk, their box and leaf tests (triangles and
# spheres) and per-lane wrappers (kernels/bvh.h, bvh_packets.h, sphere.h, scene.h), whichever the
# compiler kept out of line.
TRAVERSAL = {"traverse_bvh", "traverse_bvh_packet", "ray_slabs", "intersect_boxes", "lane_bits", "lowest_bit", "min8",
             "max8", "nearer_hit", "intersect_leaf", "intersect_triangle_block", "intersect_triangle_block_lanes",
             "intersect_sphere", "intersect_sphere_leaf_lanes", "intersect_scene", "closest_hits",
             "closest_camera_hits", "occluder", "occluded", "occluders", "coherent_occluders", "shadow_blockers"}

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


def scene_row(xml, args, scratch):
    """The table's row of one real scene: mirrored as tools/peers.py mirrors it (its cache), each
    renderer's process as peers.py's real-scene child (a warm-up render, then --renders; clrender
    with the Sobol sampler as peers.py times it, Mitsuba with the scene's `independent`)."""
    name, params, mirrors, size, _ = peers.prepare_real(xml, args.size, ["independent"], args.cache)
    ours, theirs = (
        split(perf_samples(peers.real_child_command(renderer, mirrors["independent"], params, args.spp, 1,
                                                    Path(scratch) / f"{renderer}.npy", args.variant,
                                                    batches=args.renders, sampler="sobol", warmup=True),
                           args.frequency))
        for renderer, split in (("clrender", split_clrender), ("mitsuba", split_mitsuba)))
    o_trav, o_rest, m_trav, m_rest = (n / (args.frequency * (args.renders + 1)) for n in (*ours, *theirs))
    return [f"{name} ({size})", f"{o_trav:.2f}", f"{m_trav:.2f}", f"{o_trav / m_trav:.2f}", f"{o_rest:.2f}",
            f"{m_rest:.2f}", f"{o_rest / m_rest:.2f}", f"{(o_trav + o_rest) / (m_trav + m_rest):.2f}"]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scenes", nargs="+", help="real scene folders or XML files (tools/real_scenes.py)")
    parser.add_argument("--size", type=int, default=256, help="the film's longer side")
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--renders", type=int, default=3)
    parser.add_argument("--variant", default="llvm_ad_rgb")
    parser.add_argument("--frequency", type=int, default=1000, help="perf's samples per second")
    parser.add_argument("--cache", type=Path, default=Path.home() / ".cache" / "clrender" / "peers",
                        help="the mirrored scenes (tools/peers.py's cache)")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for xml in real_scenes.scene_files(args.scenes):
            rows.append(scene_row(xml, args, scratch))
            print(f"{rows[-1][0]}: done", flush=True)
    print(f"\nCPU seconds per render of {args.spp} spp (perf samples at {args.frequency} Hz over {args.renders + 1} "
          f"renders); ratios clrender / Mitsuba ({args.variant}), above 1: clrender slower")
    print(markdown_table(["scene", "clrender traversal", "Embree", "ratio", "clrender rest", "Mitsuba rest",
                          "ratio", "render ratio"], rows))
    print(f"\n`python tools/profile_split.py {' '.join(args.scenes)} --size {args.size} --spp {args.spp} "
          f"--renders {args.renders}`")


if __name__ == "__main__":
    main()
