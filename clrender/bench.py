"""The benchmark harness every timing tool in tools/ uses: warm-up, then interleaved repeats,
medians; fresh processes timed whole.

On a machine shared with other work, absolute times drift by tens of percent from one minute to
the next. Interleaving (one run of every configuration per round, rounds repeated) spreads that
drift over all configurations alike, so the ratios between them hold; the median of the rounds
then drops the rounds a burst of load spoilt.

    runs = interleaved({"a": lambda: render_a().samples_per_second,
                        "b": lambda: render_b().samples_per_second}, rounds=5)
    print(median(runs["a"]) / median(runs["b"]), median(round_ratios(runs["a"], runs["b"])))
"""
import os
import statistics
import subprocess
import time
from dataclasses import dataclass


def interleaved(measures, rounds, warmup=1, after_round=None):
    """Call every function of `measures` (name -> function of no arguments) `warmup` times
    (results dropped: kernel builds, caches), then `rounds` rounds calling each once, in order.
    Returns name -> list of the `rounds` results (whatever the functions return).
    `after_round(number, results)`, if given, is called after each timed round with its number
    (from 1) and name -> that round's result: progress lines of long benchmarks."""
    for _ in range(warmup):
        for measure in measures.values():
            measure()
    results = {name: [] for name in measures}
    for number in range(1, rounds + 1):
        for name, measure in measures.items():
            results[name].append(measure())
        if after_round:
            after_round(number, {name: values[-1] for name, values in results.items()})
    return results


def median(values):
    return statistics.median(values)


def round_ratios(numerators, denominators):
    """The ratio of two configurations' results in each round of `interleaved`. Both results of a
    round ran under the same load, so their ratio cancels most of it: the median of these holds
    better than the ratio of the medians when the load drifts from round to round."""
    return [a / b for a, b in zip(numerators, denominators, strict=True)]


def timed(function):
    """(wall seconds, result) of one call of `function` (no arguments)."""
    start = time.perf_counter()
    result = function()
    return time.perf_counter() - start, result


def spread(values):
    """'median (min-max)' of a list of numbers, for tables."""
    return f"{median(values):.3g} ({min(values):.3g}-{max(values):.3g})"


@dataclass
class ProcessRun:
    wall_seconds: float    # from start to exit, as the user waits for it
    cpu_seconds: float     # user + system time of the process and its children
    stdout: str


def run_process(argv, env=None, cwd=None):
    """Run `argv` in a fresh process to its end and time it whole. Raises RuntimeError (with the
    process's error output) if it fails."""
    before = os.times()
    wall, done = timed(lambda: subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True))
    after = os.times()
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, argv))} failed ({done.returncode}):\n{done.stderr[-4000:]}")
    cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
    return ProcessRun(wall, cpu, done.stdout)


def checkout_comparison_arguments(description, scenes, baseline_help, spp, resolution):
    """The command line of a tool comparing renders of `scenes` (default) with another
    checkout's (--baseline): scenes, --baseline, --rounds, --spp, --resolution (image width)."""
    import argparse
    from pathlib import Path

    parser = argparse.ArgumentParser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scenes", nargs="*", default=scenes)
    parser.add_argument("--baseline", type=Path, help=baseline_help)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--spp", type=int, default=spp)
    parser.add_argument("--resolution", type=int, default=resolution, help="image width (height keeps the aspect)")
    return parser.parse_args()


def checkout_worker(checkout, source, *args):
    """A function running the Python `source` with `args` (sys.argv[1:]) in a fresh process
    whose `import clrender` is the one in the folder `checkout` (another checkout: the code
    before a change), returning the JSON value the process prints on its last line."""
    import json
    import sys

    env = dict(os.environ, PYTHONPATH=str(checkout))
    argv = [sys.executable, "-c", source, *map(str, args)]
    return lambda: json.loads(run_process(argv, env=env, cwd=checkout).stdout.strip().splitlines()[-1])


def markdown_table(header, rows):
    """A GitHub-flavoured Markdown table of strings."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)


def machine_description():
    """One line: CPU model, logical cores, OpenCL CPU device (PoCL) version, Python."""
    import platform

    model = platform.processor() or "unknown CPU"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} logical cores, Python {platform.python_version()}"
