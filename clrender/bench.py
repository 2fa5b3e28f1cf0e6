"""The benchmark harness every timing tool in tools/ uses: warm-up, then interleaved repeats,
medians; fresh processes timed whole.

On a machine shared with other work, absolute times drift by tens of percent from one minute to
the next. Interleaving (one run of every configuration per round, rounds repeated) spreads that
drift over all configurations alike, so the ratios between them hold; the median of the rounds
then drops the rounds a burst of load spoilt.

    runs = interleaved({"a": lambda: render_a().samples_per_second,
                        "b": lambda: render_b().samples_per_second}, rounds=5)
    print(median(runs["a"]) / median(runs["b"]))
"""
import os
import statistics
import subprocess
import time
from dataclasses import dataclass


def interleaved(measures, rounds, warmup=1):
    """Call every function of `measures` (name -> function of no arguments) `warmup` times
    (results dropped: kernel builds, caches), then `rounds` rounds calling each once, in order.
    Returns name -> list of the `rounds` results (whatever the functions return)."""
    for _ in range(warmup):
        for measure in measures.values():
            measure()
    results = {name: [] for name in measures}
    for _ in range(rounds):
        for name, measure in measures.items():
            results[name].append(measure())
    return results


def median(values):
    return statistics.median(values)


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
    start = time.perf_counter()
    done = subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = os.times()
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, argv))} failed ({done.returncode}):\n{done.stderr[-4000:]}")
    cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
    return ProcessRun(wall, cpu, done.stdout)


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
