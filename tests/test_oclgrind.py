"""Every feature combination, every example scene and the device test kernels run clean under
Oclgrind, an OpenCL simulator that checks every memory access: no invalid access, no
uninitialised value deciding control flow or an address or written to memory, no data race, no
out-of-range work-group, no API error.

Oclgrind prints its diagnostics on the stderr of the process using it, and is reached through
an ICD file naming its library, so the cases run in worker processes (tests/oclgrind_worker.py)
whose stderr is split by case. Settings, and why:
  OCLGRIND_UNINITIALIZED=1, OCLGRIND_DATA_RACES=1   the checks beyond memory bounds
  OCLGRIND_BUILD_OPTIONS=-cl-opt-disable           Oclgrind 21.10 (Debian 12) crashes in its
      uninitialised-value checker on shuffles with undefined lanes, which the optimiser makes
      out of float3 code; unoptimised code has none, and checks the source more literally.
  -DALBEDO_GRID=4                                  the energy-table kernel loops 192^2 times per
      entry, minutes under the simulator; its memory accesses do not depend on the loop length.
Scenes are 8 x 8 pixels (example scenes 8 pixels wide), two samples of one launch each (the
example scenes' second in bands of 4 rows, launches offset to their first row), depth 4.
Skipped when Oclgrind is not installed (apt-get install oclgrind); CI installs it.
Time: 3 minutes here (two workers in parallel; 81 s of CPU), on this shared 2-core machine.
"""
import glob
import json
import os
import subprocess
import sys
import tempfile

import pytest

import clrender
from clrender.features import all_feature_combinations, describe
from conftest import oclgrind_library

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WORKER = os.path.join(ROOT, "tests", "oclgrind_worker.py")
MARK = "@@oclgrind-case"
WORKERS = 2           # processes in parallel (one simulated work-group at a time each)
BATCHES = 6           # cases are spread over this many worker processes
TIMEOUT = 1200        # seconds per worker

LIBRARY = oclgrind_library()
pytestmark = pytest.mark.skipif(LIBRARY is None, reason="Oclgrind is not installed (apt-get install oclgrind)")

COMBINATIONS = [{"kind": "combination", "features": f} for f in all_feature_combinations()]
SCENES = [{"kind": "scene", "path": os.path.relpath(p, ROOT)}
          for p in sorted(glob.glob(os.path.join(ROOT, "scenes", "*.json")))]
# tests.cl compiles different kernels for these (see its #if blocks).
TEST_KERNELS = [{"kind": "test_kernels", "features": f} for f in
                ({}, {"ENVIRONMENT": 2, "DIELECTRIC": 1}, {"MEDIA": 1, "GRID_MEDIA": 1}, {"MEDIA": 1, "GRID_MEDIA": 2},
                 {"TEXTURES": 1})]
# A kernel with an out-of-bounds read and a branch on an uninitialised value: proves that
# diagnostics reach the test.
CANARY = {"kind": "canary"}
CASES = COMBINATIONS + SCENES + TEST_KERNELS + [CANARY]


def case_id(case):
    if case["kind"] == "combination":
        return describe(case["features"])
    if case["kind"] == "scene":
        return os.path.basename(case["path"])
    if case["kind"] == "test_kernels":
        return "tests.cl " + (",".join(f"{k}={v}" for k, v in sorted(case["features"].items())) or "base")
    return case["kind"]


def key(case):
    return json.dumps(case, sort_keys=True)


def cost(case):
    """A rough relative cost under the simulator, to balance the workers."""
    if case["kind"] != "combination":
        return 3
    f = case["features"]
    return 1 + 2 * f["MEDIA"] + 2 * f["DIELECTRIC"] + 6 * bool(f["GRID_MEDIA"]) + 4 * (f["GRID_MEDIA"] == 2)


def batches(cases, count):
    """Greedy balance: the costliest cases first, each to the least loaded batch."""
    loads = [[0, []] for _ in range(count)]
    for case in sorted(cases, key=cost, reverse=True):
        target = min(loads, key=lambda load: load[0])
        target[0] += cost(case)
        target[1].append(case)
    return [cases for _, cases in loads if cases]


def split_by_case(stderr, cases, returncode):
    """case key -> the stderr text printed while it ran ('' when clean)."""
    text = {key(case): None for case in cases}
    current, outside = None, []
    for line in stderr.splitlines():
        if line.startswith(f"{MARK} begin "):
            current = line[len(f"{MARK} begin "):]
            text[current] = ""
        elif line.startswith(f"{MARK} end "):
            current = None
        elif current is not None:
            text[current] += line + "\n"
        elif line.strip():
            outside.append(line)
    if current is not None:
        text[current] += f"the worker died during this case (exit status {returncode})\n"
    for k, value in text.items():
        if value is None:
            text[k] = f"not run: the worker stopped earlier (exit status {returncode})\n"
        elif outside:
            text[k] += "printed outside any case:\n" + "\n".join(outside) + "\n"
    return text


@pytest.fixture(scope="module")
def oclgrind_results():
    """Run every case under Oclgrind: key -> (stderr text, the worker's report or None)."""
    with tempfile.TemporaryDirectory() as folder:
        icd = os.path.join(folder, "vendors")
        os.mkdir(icd)
        with open(os.path.join(icd, "oclgrind.icd"), "w") as f:
            f.write(LIBRARY + "\n")
        package_root = os.path.dirname(os.path.dirname(os.path.abspath(clrender.__file__)))
        env = dict(os.environ, OCL_ICD_VENDORS=icd, OCLGRIND_UNINITIALIZED="1", OCLGRIND_DATA_RACES="1",
                   OCLGRIND_BUILD_OPTIONS="-cl-opt-disable -DALBEDO_GRID=4",
                   PYOPENCL_NO_CACHE="1",                        # build for this device and these options
                   CLRENDER_CACHE_DIR=os.path.join(folder, "cache"),
                   PYTHONPATH=os.pathsep.join([package_root, os.environ.get("PYTHONPATH", "")]))
        results = {}
        pending = list(enumerate(batches(CASES, BATCHES)))
        running = []
        while pending or running:
            while pending and len(running) < WORKERS:
                number, cases = pending.pop(0)
                # Files, not pipes: a worker printing many diagnostics never blocks on a full pipe.
                streams = [open(os.path.join(folder, f"{number}.{name}"), "w+") for name in ("out", "err")]
                process = subprocess.Popen([sys.executable, WORKER], stdin=subprocess.PIPE, stdout=streams[0],
                                           stderr=streams[1], text=True, env=env, cwd=ROOT)
                process.stdin.write(json.dumps(cases))
                process.stdin.close()
                running.append((process, cases, streams))
            process, cases, streams = running.pop(0)
            try:
                process.wait(timeout=TIMEOUT)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
            stdout, stderr = (stream.seek(0) or stream.read() for stream in streams)
            for stream in streams:
                stream.close()
            reports = {}
            for line in stdout.splitlines():
                if line.startswith("{"):
                    report = json.loads(line)
                    reports[report.pop("case")] = report
            for k, text in split_by_case(stderr, cases, process.returncode).items():
                results[k] = (text, reports.get(k))
        return results


@pytest.mark.parametrize("case", [c for c in CASES if c is not CANARY], ids=case_id)
def test_no_oclgrind_diagnostics(oclgrind_results, case):
    diagnostics, report = oclgrind_results[key(case)]
    assert diagnostics == "", f"Oclgrind reported, for {case_id(case)}:\n{diagnostics}"
    if case["kind"] in ("combination", "scene"):
        assert report["discarded"] == 0 and report["finite"]


def test_oclgrind_diagnostics_reach_the_test(oclgrind_results):
    diagnostics, _ = oclgrind_results[key(CANARY)]
    assert "Invalid read" in diagnostics and "uninitialized value" in diagnostics, diagnostics
