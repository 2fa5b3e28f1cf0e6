"""The benchmark harness (clrender/bench.py) with fake measures: call order, warm-up dropped,
per-round results and ratios, timing. No rendering; well under a second."""
import sys

import pytest

from clrender import bench


def counting(log, name, values):
    """A measure that logs its calls and returns the next of `values`."""
    values = iter(values)

    def measure():
        log.append(name)
        return next(values)
    return measure


def test_interleaved_warms_up_then_alternates_and_drops_the_warm_up():
    log, rounds = [], []
    measures = {"a": counting(log, "a", [100, 1, 2, 3]), "b": counting(log, "b", [200, 10, 20, 30])}
    runs = bench.interleaved(measures, rounds=3, warmup=1,
                             after_round=lambda number, results: rounds.append((number, results, len(log))))
    assert log == ["a", "b"] * 4
    assert runs == {"a": [1, 2, 3], "b": [10, 20, 30]}
    # after_round sees each timed round once it is complete, numbered from 1.
    assert rounds == [(1, {"a": 1, "b": 10}, 4), (2, {"a": 2, "b": 20}, 6), (3, {"a": 3, "b": 30}, 8)]


def test_round_ratios_pair_results_of_the_same_round():
    # A load burst in round 2 slows both alike: the per-round ratio stays 2, the medians' ratio does not.
    a, b = [2.0, 8.0, 2.2, 2.1], [1.0, 4.0, 1.1, 1.05]
    assert bench.round_ratios(a, b) == pytest.approx([2.0, 2.0, 2.0, 2.0])
    with pytest.raises(ValueError):
        bench.round_ratios([1.0, 2.0], [1.0])


def test_timed_returns_the_seconds_between_two_clock_readings_and_the_result(monkeypatch):
    clock = iter([10.0, 12.5])
    monkeypatch.setattr(bench.time, "perf_counter", lambda: next(clock))
    assert bench.timed(lambda: "result") == (2.5, "result")


def test_run_process_returns_output_and_raises_with_the_error_output():
    done = bench.run_process([sys.executable, "-c", "print('hello')"])
    assert done.stdout == "hello\n" and done.wall_seconds > 0
    with pytest.raises(RuntimeError, match="broken"):
        bench.run_process([sys.executable, "-c", "import sys; sys.exit('broken')"])


def test_spread_and_markdown_table():
    assert bench.spread([3.0, 1.0, 2.0]) == "2 (1-3)"
    assert bench.markdown_table(["x", "y"], [[1, "a"]]) == "| x | y |\n|---|---|\n| 1 | a |"
