"""Kernel build times for a scene: cold (empty caches: compile from source, then the first launch,
where PoCL generates the machine code) and warm (a new process would hit the caches: program
binary from clrender's disk cache, kernel from PoCL's cache). Each measured in a fresh process,
with the CPU time of that process (user + system: the compiler's work, which the load of a shared
machine disturbs less than wall time).

    python tools/bench_build.py [scenes/cornell_box.json] [--runs 3] [--roots DIR ...]

CPU seconds (of the build, and of the build and first launch, in the probe process) are reported
beside the wall times: on a shared machine they hold better.

`--roots`: checkouts of clrender to compare (default: this one), e.g. another branch's worktree
or a commit unpacked with `git archive COMMIT | tar -x -C /tmp/old`; rounds interleave them, and
the cold build of each root is also given as the median of its per-round ratios to the first's.
"""
import argparse
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from clrender.bench import interleaved, median, round_ratios, run_process  # noqa: E402
PROBE = """
import resource
import sys
sys.path.insert(0, {root!r})
import pyopencl as cl
import clrender
from clrender.bench import timed
from clrender.device import build_program
from clrender.features import scene_features
def cpu():
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime
scene = clrender.load_scene({scene!r})
context = cl.Context([clrender.choose_device({device!r})])
queue = cl.CommandQueue(context)
start = cpu()
build, _ = timed(lambda: build_program(context, scene_features(scene)))
built = cpu()
# The first launch: PoCL compiles the kernel for the device here.
launch, _ = timed(lambda: clrender.Renderer(scene, context.devices[0]).render(spp=1, max_depth=1))
print(build, build + launch, built - start, cpu() - start)
"""


def probe(root, scene, device, cache):
    """Wall and CPU seconds of `root`'s build and build + first launch."""
    env = dict(os.environ, CLRENDER_CACHE_DIR=cache, POCL_CACHE_DIR=cache + "/pocl")
    code = PROBE.format(root=str(root), scene=str(scene), device=device)
    return tuple(map(float, run_process([sys.executable, "-c", code], env=env).stdout.split()))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scene", nargs="?", default=str(ROOT / "scenes" / "cornell_box.json"))
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--roots", type=Path, nargs="+", default=[ROOT])
    args = parser.parse_args()
    caches = {}
    measures = {}
    for root in args.roots:
        def cold(root=root):   # an empty cache per round, which the warm probe then finds filled
            caches.setdefault(root, []).append(tempfile.TemporaryDirectory())
            return probe(root, args.scene, args.device, caches[root][-1].name)

        def warm(root=root):
            return probe(root, args.scene, args.device, caches[root][-1].name)
        measures[(root, "cold")], measures[(root, "warm")] = cold, warm

    runs = interleaved(measures, rounds=args.runs, warmup=0)
    for cache in (c for root_caches in caches.values() for c in root_caches):
        cache.cleanup()
    for (root, label), results in runs.items():
        build, total, build_cpu, total_cpu = (median([r[k] for r in results]) for k in range(4))
        print(f"{root} {label}: program build {build:.3f} s ({build_cpu:.3f} s CPU), build + first launch "
              f"{total:.3f} s ({total_cpu:.3f} s CPU) (median of {args.runs})")
    first = runs[(args.roots[0], "cold")]
    names = ("program build", "build + first launch", "program build CPU", "build + first launch CPU")
    for root in args.roots[1:]:
        cold = runs[(root, "cold")]
        for k, name in enumerate(names):
            ratio = median(round_ratios([r[k] for r in cold], [r[k] for r in first]))
            print(f"{root} / {args.roots[0]}, cold {name}: {ratio:.3f} (median of per-round ratios)")


if __name__ == "__main__":
    main()
