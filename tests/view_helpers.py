"""Shared by tests/test_view.py, tests/test_view_browser.py and tools/view_screenshot.py: a
small Cornell box, frame decoding, the images a viewer should show, headless Chromium."""
import contextlib
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile

import numpy as np

import clrender

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CORNELL = os.path.join(REPO, "scenes", "cornell_box.json")


def cornell_box(size=64, **render):
    """The example Cornell box at size x size pixels, with `render` settings changed."""
    with open(CORNELL) as f:
        data = json.load(f)
    data["camera"]["resolution"] = [size, size]
    data["render"].update(render)
    return clrender.load_scene_dict(data)


def start_command(*args):
    """`clrender view ARGS --no-browser` as a process, and the URL it serves (warnings, e.g. a
    driver's compiler output, may come first on stderr)."""
    command = subprocess.Popen([sys.executable, "-m", "clrender.cli", "view", *args, "--no-browser"], cwd=REPO,
                               stderr=subprocess.PIPE, text=True)
    for line in command.stderr:
        found = re.search(r"view at (http://\S+/)", line)
        if found:
            return command, found.group(1)
    command.wait()
    raise AssertionError(f"clrender view exited with {command.returncode} before serving")


def decode_frame(message):
    """(header, pixels (H, W, 3)) of a binary frame message (clrender/view/frames.py)."""
    (length,) = struct.unpack_from("<I", message)
    header = json.loads(message[4:4 + length])
    dtype = "<f4" if header["kind"] == "radiance" else np.uint8
    pixels = np.frombuffer(message, dtype, offset=4 + length)
    return header, pixels.reshape(header["height"], header["width"], 3)


def rendered(scene, device, spp, seed=None):
    """The RenderResult of `spp` samples with every AOV: what a viewer's snapshot of `spp`
    samples must hold (the viewer accumulates the AOVs too)."""
    return clrender.Renderer(scene, device).render(spp=spp, seed=seed, aovs=clrender.AOV_NAMES)


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")
# Chromium as root in a container, quiet towards the (closed) network.
CHROMIUM_FLAGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--disable-dev-shm-usage")


@contextlib.contextmanager
def headless_chromium(width=900, height=700):
    """A selenium driver of headless Chromium (Debian's chromium and chromium-driver) with a
    fresh profile, removed afterwards."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    profile = tempfile.mkdtemp(prefix="clrender-chromium-")
    for flag in CHROMIUM_FLAGS + (f"--window-size={width},{height}", f"--user-data-dir={profile}"):
        options.add_argument(flag)
    driver = webdriver.Chrome(options=options, service=Service(CHROMEDRIVER))
    driver.set_page_load_timeout(30)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)
