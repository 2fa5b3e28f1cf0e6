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
import statistics
import sys
import time
from pathlib import Path

os.environ["POCL_MAX_PTHREAD_COUNT"] = "1"   # before PoCL starts, here and in the workers
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import clrender  # noqa: E402
from clrender import distributed  # noqa: E402


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


def timed(function):
    """(wall seconds, CPU seconds of every process involved, result)."""
    start, cpu = time.perf_counter(), cpu_seconds()
    result = function()
    return time.perf_counter() - start, cpu_seconds() - cpu, result


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
    runs = {"local": [], "1 worker": [], "2 workers": [], "one chunk": [], "many chunks": []}
    cpu = {"local": [], "1 worker": [], "2 workers": []}
    for run in range(args.runs):
        seconds, cpu_time, _ = timed(lambda: renderer.render(spp=spp))
        runs["local"].append(seconds)
        cpu["local"].append(cpu_time)
        # One cluster at a time, so the CPU time counts only the processes at work.
        for workers, name in ((1, "1 worker"), (2, "2 workers")):
            with cluster(workers) as local_cluster, Client(local_cluster) as client:
                # Warm-up: kernel loads and PoCL compiles per worker process.
                distributed.render(scene, client, 2, device=args.device, samples_per_chunk=1)
                distributed.render(tiny, client, 2, device=args.device, tiles=1, samples_per_chunk=1)
                seconds, cpu_time, result = timed(lambda: distributed.render(scene, client, spp, device=args.device))
                assert (result.image == reference).all(), "distributed image differs from the local one"
                runs[name].append(seconds)
                cpu[name].append(cpu_time)
                if workers == 1:
                    for chunks, per_chunk in (("one chunk", args.chunks), ("many chunks", 1)):
                        runs[chunks].append(timed(lambda: distributed.render(
                            tiny, client, args.chunks, device=args.device, tiles=1, samples_per_chunk=per_chunk))[0])
        print(f"run {run + 1}: " + ", ".join(f"{k} {v[-1]:.2f} s" for k, v in runs.items())
              + f"; load average {os.getloadavg()[0]:.1f}", flush=True)
    median = {name: statistics.median(values) for name, values in runs.items()}
    efficiencies = [a / (2 * b) for a, b in zip(runs["1 worker"], runs["2 workers"])]
    overheads = [(many - one) / (args.chunks - 1) for one, many in zip(runs["one chunk"], runs["many chunks"])]
    print("median seconds: " + ", ".join(f"{k} {v:.2f}" for k, v in median.items()))
    print(f"speed-up of 2 workers over 1: {median['1 worker'] / median['2 workers']:.2f}; "
          f"efficiency {statistics.median(efficiencies):.2f} (runs: {', '.join(f'{e:.2f}' for e in efficiencies)})")
    print(f"1 worker against the local render: {median['1 worker'] / median['local']:.3f}x the time")
    cpu_median = {name: statistics.median(values) for name, values in cpu.items()}
    print("median CPU seconds: " + ", ".join(f"{k} {v:.2f}" for k, v in cpu_median.items())
          + f"; 1 worker {cpu_median['1 worker'] / cpu_median['local']:.3f}x and 2 workers "
          f"{cpu_median['2 workers'] / cpu_median['local']:.3f}x the local render's")
    print(f"overhead per chunk: {statistics.median(overheads) * 1000:.1f} ms "
          f"(runs: {', '.join(f'{o * 1000:.1f}' for o in overheads)} ms)")
    print(f"load average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
