"""The command line end to end, run as a user would (a subprocess)."""
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import clrender
from clrender.features import all_feature_combinations
from conftest import TEST_DEVICE

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(*args, timeout=300, **kwargs):
    return subprocess.run([sys.executable, "-m", "clrender.cli", *args], capture_output=True,
                          text=True, cwd=REPO, timeout=timeout, **kwargs)


def test_render_cornell_box_to_png_and_exr(tmp_path):
    png, exr = tmp_path / "cb.png", tmp_path / "cb.exr"
    result = run("render", "scenes/cornell_box.json", "-o", str(png), "--spp", "2", "--device", TEST_DEVICE)
    assert result.returncode == 0, result.stderr
    assert "M samples/s" in result.stderr
    assert run("render", "scenes/cornell_box.json", "-o", str(exr), "--spp", "2", "--quiet").returncode == 0
    linear = clrender.load_image(exr)
    assert linear.shape == (256, 256, 3) and np.all(np.isfinite(linear))
    assert linear.mean() > 0.05  # lit, not black
    import imageio.v3 as iio
    assert iio.imread(png).shape == (256, 256, 3)


def test_render_for_a_fixed_time(tmp_path):
    out = tmp_path / "timed.png"
    result = run("render", "scenes/cornell_box.json", "-o", str(out), "--time", "0.5", "--quiet")
    assert result.returncode == 0, result.stderr
    assert out.exists() and " spp in " in result.stderr


def test_info_and_devices():
    info = run("info", "scenes/cornell_box.json")
    assert info.returncode == 0
    assert "triangles:  36" in info.stdout and "features:   environment=none" in info.stdout
    devices = run("devices")
    assert devices.returncode == 0 and "0:" in devices.stdout


def test_info_kernel_reports_what_a_device_needs():
    scene = run("info", "scenes/cornell_box.json", "--kernel", "--device", TEST_DEVICE)
    assert scene.returncode == 0, scene.stderr
    assert "bytes private memory per work-item" in scene.stdout and "for one sample per pixel" in scene.stdout
    # Every combination built: 196 builds of 1-4 s each with a cold kernel cache (then cached
    # for test_compile.py).
    table = run("info", "--kernel", "--no-launch", "--device", TEST_DEVICE, timeout=1500)
    assert table.returncode == 0, table.stderr
    rows = [line.split() for line in table.stdout.splitlines() if line.startswith("environment=")]
    assert len(rows) == len(list(all_feature_combinations()))
    assert all(int(row[-3]) >= 0 and int(row[-2]) >= 1 and int(row[-1]) >= 1 for row in rows)
    assert run("info").returncode == 2   # neither a scene nor --kernel: bad arguments (docs/errors.md)


@pytest.mark.parametrize("content,message", [
    (None, "scene file not found"),
    ("{not json", "invalid JSON at line 1"),
    (json.dumps({"camera": {"position": [0, 0, 1], "look_at": [0, 0, 0]},
                 "materials": [{"name": "a", "type": "glass"}]}), "materials[0].type: unknown value 'glass'"),
    (json.dumps({"camera": {"position": [0, 0, 1], "look_at": [0, 0, 0]},
                 "materials": [{"name": "a", "type": "diffuse"}],
                 "shapes": [{"type": "mesh", "file": "missing.obj", "material": "a"}]}),
     "shapes[0].file: file not found"),
])
def test_bad_input_fails_cleanly_without_output(tmp_path, content, message):
    scene = tmp_path / "scene.json"
    if content is not None:
        scene.write_text(content)
    out = tmp_path / "out.png"
    result = run("render", str(scene), "-o", str(out), "--spp", "1")
    assert result.returncode == 3   # a bad scene (docs/errors.md)
    assert message in result.stderr and "Traceback" not in result.stderr
    assert list(tmp_path.iterdir()) == ([scene] if content is not None else [])


def test_bad_arguments_exit_non_zero(tmp_path):
    assert run("render", "scenes/cornell_box.json", "-o", str(tmp_path / "x.png"), "--spp", "0").returncode == 2
    result = run("render", "scenes/cornell_box.json", "-o", str(tmp_path / "x.gif"), "--spp", "1")
    assert result.returncode == 2 and "unsupported image format" in result.stderr
    result = run("render", "scenes/cornell_box.json", "-o", str(tmp_path / "x.png"), "--device", "7")
    assert result.returncode == 2 and "out of range" in result.stderr
    assert not any(tmp_path.iterdir())


def test_ctrl_c_saves_the_partial_image(tmp_path):
    out = tmp_path / "partial.exr"
    process = subprocess.Popen([sys.executable, "-m", "clrender.cli", "render", "scenes/cornell_box.json",
                                "-o", str(out), "--spp", "100000"], cwd=REPO,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    line = ""
    while "spp" not in line and time.time() < deadline:  # wait until the progress bar moves
        line = process.stderr.read(64)
    time.sleep(1.0)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr
    assert "partial image saved" in stderr
    image = clrender.load_image(out)
    assert np.all(np.isfinite(image)) and image.mean() > 0.05
