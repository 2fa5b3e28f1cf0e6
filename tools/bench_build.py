"""Kernel build times for a scene: cold (empty caches: compile from source, then the first launch,
where PoCL generates the machine code) and warm (a new process would hit the caches: program
binary from clrender's disk cache, kernel from PoCL's cache). Each measured in a fresh process.

    python tools/bench_build.py [scenes/cornell_box.json] [--runs 3]
"""
import argparse
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from clrender.bench import interleaved, median, run_process  # noqa: E402
PROBE = """
import sys
sys.path.insert(0, {root!r})
import pyopencl as cl
import clrender
from clrender.bench import timed
from clrender.device import build_program
from clrender.features import scene_features
scene = clrender.load_scene({scene!r})
context = cl.Context([clrender.choose_device({device!r})])
queue = cl.CommandQueue(context)
build, _ = timed(lambda: build_program(context, scene_features(scene)))
# The first launch: PoCL compiles the kernel for the device here.
launch, _ = timed(lambda: clrender.Renderer(scene, context.devices[0]).render(spp=1, max_depth=1))
print(build, build + launch)
"""


def probe(scene, device, cache):
    env = dict(os.environ, CLRENDER_CACHE_DIR=cache, POCL_CACHE_DIR=cache + "/pocl")
    code = PROBE.format(root=str(ROOT), scene=str(scene), device=device)
    build, first_launch = map(float, run_process([sys.executable, "-c", code], env=env).stdout.split())
    return build, first_launch


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scene", nargs="?", default=str(ROOT / "scenes" / "cornell_box.json"))
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args()
    caches = []

    def cold():   # an empty cache per round, which the warm probe of the round then finds filled
        caches.append(tempfile.TemporaryDirectory())
        return probe(args.scene, args.device, caches[-1].name)

    def warm():
        return probe(args.scene, args.device, caches[-1].name)

    runs = interleaved({"cold": cold, "warm": warm}, rounds=args.runs, warmup=0)
    for cache in caches:
        cache.cleanup()
    for label, results in runs.items():
        build = median([r[0] for r in results])
        total = median([r[1] for r in results])
        print(f"{label}: program build {build:.3f} s, build + first launch {total:.3f} s "
              f"(median of {args.runs})")


if __name__ == "__main__":
    main()
