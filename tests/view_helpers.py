"""Shared by tests/test_view.py and tests/test_view_browser.py: a small Cornell box, frame
decoding, the images a viewer should show."""
import json
import os
import struct

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
