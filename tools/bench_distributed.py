"""Distributed rendering: the scaling of 2 Dask workers against 1, and the overhead per chunk.

    python tools/bench_distributed.py [--scene scenes/cornell_box.json] [--resolution 128 96]
                                      [--seconds 20] [--runs 3] [--chunks 200]

This process and every worker use one PoCL thread (POCL_MAX_PTHREAD_COUNT=1), so a worker is one
core, and every worker starts its own session (os.setsid in the preload hook below): with Linux's
autogroup scheduling the CPU is shared between sessions, so on a busy shared machine two worker
processes of one session would get no more CPU than one; in sessions of their own each gets a
share of its own, like a core of its own. The spp is chosen so that one worker needs about --seconds. Per run, interleaved (so a
change in the machine's load hits every configuration alike):
  local      Renderer.render in this process (no Dask)
  1 worker   distributed.render on a LocalCluster of 1 worker (default strips and chunks)
  2 workers  the same on a LocalCluster of 2 workers
  overhead   1 worker, a 16x16 image in one strip: --chunks chunks of 1 sample against one chunk
             of --chunks samples; the difference over (chunks - 1) is the cost of a chunk beyond
             its kernel time (client round trip, scheduling, transfers, upload and download).
Efficiency = t(1 worker) / (2 t(2 workers)). Medians over the runs. Also the CPU time of all the
processes (this one with its in-process scheduler, and the workers) per render: unlike wall time
it hardly depends on what else runs on the machine. Results: docs/distributed.md.
"""
import argparse
import logging
import math
import os
import sys
from pathlib import Path

os.environ["POCL_MAX_PTHREAD_COUNT"] = "1"   # before PoCL starts, here and in the workers
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import clrender  # noqa: E402
from clrender import distributed  # noqa: E402
from clrender.bench import interleaved, median, round_ratios, timed  # noqa: E402


def dask_setup(worker):
    """Dask preload hook of the benchmark's workers: a session (autogroup) of their own."""
    os.setsid()


def cpu_seconds():
    """CPU time of this process (client, in-process scheduler) and its children (the workers)."""
    import psutil

    processes = [psutil.Process()] + psutil.Process().children(recursive=True)
    total = 0.0
    for process in processes:
        try:
            times = process.cpu_times()
            total += times.user + times.system
        except psutil.NoSuchProcess:
            pass
    return total


def timed_with_cpu(function):
    """{"seconds": wall seconds, "cpu": CPU seconds of every process involved}, result."""
    cpu = cpu_seconds()
    seconds, result = timed(function)
    return {"seconds": seconds, "cpu": cpu_seconds() - cpu}, result


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", default="scenes/cornell_box.json")
    parser.add_argument("--resolution", type=int, nargs=2, default=(128, 96))
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--chunks", type=int, default=200)
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args()
    from distributed import Client, LocalCluster

    scene = clrender.load_scene(args.scene)
    scene.camera.resolution = tuple(args.resolution)
    renderer = clrender.Renderer(scene, args.device)
    renderer.render(spp=1)
    rate = renderer.render(spp=8).samples_per_second
    spp = max(8, int(args.seconds * rate / math.prod(args.resolution)))
    print(f"{args.scene} at {args.resolution[0]}x{args.resolution[1]}, {spp} spp, device {args.device}, "
          f"1 PoCL thread per process; load average before: {os.getloadavg()[0]:.1f}")

    def cluster(workers):
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                            silence_logs=logging.CRITICAL, preload=[str(Path(__file__).resolve())])

    tiny = clrender.load_scene(args.scene)
    tiny.camera.resolution = (16, 16)
    reference = renderer.render(spp=spp).image

    def local():
        return timed_with_cpu(lambda: renderer.render(spp=spp))[0]

    def on_cluster(workers):
        """A function timing the render on a fresh cluster of `workers` (one cluster at a time, so
        the CPU time counts only the processes at work); with 1 worker also the chunk overhead's
        two renders ("one chunk", "many chunks": wall seconds)."""
        def measure():
            with cluster(workers) as local_cluster, Client(local_cluster) as client:
                # Warm-up: kernel loads and PoCL compiles per worker process.
                distributed.render(scene, client, 2, device=args.device, samples_per_chunk=1)
                distributed.render(tiny, client, 2, device=args.device, tiles=1, samples_per_chunk=1)
                times, result = timed_with_cpu(lambda: distributed.render(scene, client, spp, device=args.device))
                assert (result.image == reference).all(), "distributed image differs from the local one"
                if workers == 1:
                    for chunks, per_chunk in (("one chunk", args.chunks), ("many chunks", 1)):
                        times[chunks] = timed(lambda: distributed.render(
                            tiny, client, args.chunks, device=args.device, tiles=1, samples_per_chunk=per_chunk))[0]
                return times
        return measure

    wall = []   # per run: name -> wall seconds, the chunk renders of "1 worker" under their own names

    def progress(number, results):
        wall.append({name: r["seconds"] for name, r in results.items()})
        wall[-1].update((chunks, results["1 worker"][chunks]) for chunks in ("one chunk", "many chunks"))
        print(f"run {number}: " + ", ".join(f"{k} {v:.2f} s" for k, v in wall[-1].items())
              + f"; load average {os.getloadavg()[0]:.1f}", flush=True)

    results = interleaved({"local": local, "1 worker": on_cluster(1), "2 workers": on_cluster(2)},
                          rounds=args.runs, warmup=0, after_round=progress)
    runs = {name: [seconds[name] for seconds in wall] for name in wall[0]}
    medians = {name: median(values) for name, values in runs.items()}
    efficiencies = [ratio / 2 for ratio in round_ratios(runs["1 worker"], runs["2 workers"])]
    overheads = [(many - one) / (args.chunks - 1) for one, many in zip(runs["one chunk"], runs["many chunks"])]
    print("median seconds: " + ", ".join(f"{k} {v:.2f}" for k, v in medians.items()))
    print(f"speed-up of 2 workers over 1: {medians['1 worker'] / medians['2 workers']:.2f}; "
          f"efficiency {median(efficiencies):.2f} (runs: {', '.join(f'{e:.2f}' for e in efficiencies)})")
    print(f"1 worker against the local render: {medians['1 worker'] / medians['local']:.3f}x the time")
    cpu_median = {name: median([r["cpu"] for r in values]) for name, values in results.items()}
    print("median CPU seconds: " + ", ".join(f"{k} {v:.2f}" for k, v in cpu_median.items())
          + f"; 1 worker {cpu_median['1 worker'] / cpu_median['local']:.3f}x and 2 workers "
          f"{cpu_median['2 workers'] / cpu_median['local']:.3f}x the local render's")
    print(f"overhead per chunk: {median(overheads) * 1000:.1f} ms "
          f"(runs: {', '.join(f'{o * 1000:.1f}' for o in overheads)} ms)")
    print(f"load average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
