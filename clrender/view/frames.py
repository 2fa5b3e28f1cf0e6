"""What the page is sent after each pass: one layer of the latest Accumulation, as one binary
WebSocket message.

A message is a little-endian uint32 N, then N bytes of a JSON header (padded with spaces so that
the pixels start at a multiple of 4 bytes), then the pixels, row-major from the top-left:
    kind "radiance"  float32 RGB, linear: the page tone-maps them (exposure, curve: tonemap.py)
    kind "display"   uint8 RGB, ready to show: the 8-bit views of image.ldr_layer (normals as
                     (n + 1) / 2, depth as grey, object ids as colours, albedo sRGB-encoded)
The header carries the layer, its kind and size, and the render's progress (`frame_header`).
"""
import json
import struct
import threading

import numpy as np

from ..aovs import AOV_NAMES
from ..denoise import DenoiseSettings
from ..image import ldr_layer
from ..render import image_result
from ..splatting import splats
from .camera import describe

# The layers the page can show: the image, the denoised image (with pyoidn), every AOV.
# Radiance layers are sent linear and tone-mapped by the page; the others as 8-bit views.
RADIANCE_LAYERS = ("image", "denoised", "emission", "variance")


def layer_names(denoiser):
    """The layers of the page's switcher; "denoised" only where Open Image Denoise is installed."""
    return ("image",) + (("denoised",) if denoiser else ()) + AOV_NAMES


def relative_noise(image, variance):
    """The estimated relative RMS error of `image` against the converged one: sqrt(sum of the
    per-pixel variances of the mean / sum of squared values), from the variance AOV; None before
    the second sample (the variance is unknown, inf) or for a black image. The variance AOV is
    that of a mean of independent samples: with the Sobol sampler, whose samples are stratified,
    the true error is lower (about a quarter of the estimate on the Cornell box at 16 spp), and so
    it is when splatting averages neighbours' samples into each pixel: this is then an upper
    bound (frame_header's noise_bound)."""
    if not np.all(np.isfinite(variance)):
        return None
    energy = float(np.sum(np.square(image, dtype=np.float64)))
    return float(np.sqrt(np.sum(variance, dtype=np.float64) / energy)) if energy > 0 else None


class Views:
    """The images of one Snapshot, made when first asked for (from any thread) and kept: the
    RenderResult with every AOV, the denoised image, the encoded message of each layer."""

    def __init__(self, snapshot):
        self.snapshot = snapshot
        self._lock = threading.RLock()   # a message makes the result it shows under the same lock
        self._cache = {}

    def _once(self, key, make):
        with self._lock:
            if key not in self._cache:
                self._cache[key] = make()
            return self._cache[key]

    def result(self):
        """The RenderResult of the snapshot with every AOV (outlines composited, as `render` makes it)."""
        return self._once("result", lambda: image_result(self.snapshot.scene, self.snapshot.state, AOV_NAMES))

    def denoised(self):
        """The image denoised by Open Image Denoise, guided by the albedo and normal AOVs."""
        settings = DenoiseSettings()
        return self._once("denoised", lambda: image_result(self.snapshot.scene, self.snapshot.state,
                                                           settings.aovs(), settings).image)

    def layer(self, name):
        """(kind, pixels) of a layer: "radiance" float32 or "display" uint8 (H, W, 3)."""
        result = self.result()
        if name == "image":
            return "radiance", result.image
        if name == "denoised":
            return "radiance", self.denoised()
        if name == "variance":   # shown as the standard error, in radiance units (as ldr_layer does)
            return "radiance", np.sqrt(np.maximum(result.aovs["variance"], 0.0))
        if name in RADIANCE_LAYERS:
            return "radiance", result.aovs[name]
        return "display", ldr_layer(name, result.aovs[name])

    def noise(self):
        result = self.result()
        return relative_noise(result.image, result.aovs["variance"])

    def message(self, name):
        """The binary message of layer `name` (module docstring)."""
        def make():
            kind, pixels = self.layer(name)
            return encode_frame(frame_header(self.snapshot, name, kind, self.noise()), pixels)
        return self._once(("message", name), make)


def frame_header(snapshot, layer, kind, noise):
    """The JSON header of a frame: the layer, and the progress of the render it shows."""
    state = snapshot.state
    width, height = snapshot.scene.camera.resolution
    return {"type": "frame", "layer": layer, "kind": kind, "width": width, "height": height,
            "generation": snapshot.generation, "samples": state.samples, "target": snapshot.target,
            "samples_per_second": state.samples * width * height / state.seconds if state.seconds > 0 else 0.0,
            "seconds": snapshot.seconds, "noise": noise, "noise_bound": noise_is_bounded(snapshot.scene),
            "done": state.samples >= snapshot.target,
            "camera": describe(snapshot.scene.camera)}


def noise_is_bounded(scene):
    """Whether relative_noise over-estimates the error of `scene`'s renders: stratified samples,
    or splatted pixels."""
    return scene.render.sampler == "sobol" or splats(scene)


def encode_frame(header, pixels):
    """uint32 N, the JSON header in N bytes (space-padded to a multiple of 4), the pixels."""
    text = json.dumps(header).encode()
    text += b" " * (-len(text) % 4)
    dtype = np.float32 if header["kind"] == "radiance" else np.uint8
    data = np.ascontiguousarray(pixels, dtype=np.dtype(dtype).newbyteorder("<"))
    return struct.pack("<I", len(text)) + text + data.tobytes()
