"""Denoising with Intel Open Image Denoise (OIDN) through the optional `pyoidn` package.

The "RT" filter on the CPU device, in high-quality mode, with the colour as HDR (our radiance is
unbounded: a Cornell box light is 17 units bright, and an LDR filter would clip it), guided by
the albedo and normal AOVs (aovs.py: first non-delta vertex, as OIDN recommends). Optionally
the emission seen directly (the emission AOV) is left out of the filter and added back: emitters
then stay exact (no halo, no noise of the filter's own), but their anti-aliased edges keep their
raw noise; docs/denoising.md measures both. Those guides
are noisy where the path picks between lobes (glass) or scatters in media; `prefilter=True`
denoises them first and tells the filter they are clean (OIDN's final-frame recipe, about three
times the cost): docs/denoising.md measures both.

pyoidn is an optional dependency: `pip install -e '.[denoise]'`.
"""
import functools
from dataclasses import dataclass

import numpy as np

from .errors import ArgumentError, DenoiserUnavailable, DeviceError

INSTALL_HINT = "pip install 'clrender[denoise]' (or: pip install pyoidn)"
# OIDN's network needs context around a pixel: a 1x1 image came back at 9% of its brightness, a
# one-row one at 70%, 16x16 within 1%. Smaller images are centred in an image of this side, their
# edges repeated, and the result cropped: constant images of any size then come back within 1%
# (OIDN's own corner pixels are 2-4% off, so not padded on one side only).
MIN_SIDE = 32


@dataclass(frozen=True)
class DenoiseSettings:
    """How a render is denoised: `prefilter` the guides first; `keep_emission` (the emission AOV)
    out of the filter."""
    prefilter: bool = False
    keep_emission: bool = False

    def aovs(self):
        """The AOVs the denoiser takes beside the colour."""
        return ("albedo", "normal") + (("emission",) if self.keep_emission else ())


def denoise_render(image, aovs, settings):
    """`image` denoised with its AOVs (name -> array, holding settings.aovs())."""
    return denoise(image, aovs["albedo"], aovs["normal"], settings.prefilter,
                   aovs["emission"] if settings.keep_emission else None)


def _oidn(where="denoise"):
    try:
        import pyoidn
    except ImportError as e:
        raise DenoiserUnavailable(
            where, f"denoising needs Intel Open Image Denoise: {INSTALL_HINT} ({e})") from None
    return pyoidn


@functools.lru_cache(maxsize=None)
def _device():
    """One OIDN CPU device per process (creating one costs about 0.1 s)."""
    oidn = _oidn()
    device = oidn.Device(oidn.OIDN_DEVICE_TYPE_CPU)
    device.commit()
    return device


def check_denoiser(where="denoise"):
    """Raise DenoiserUnavailable (naming `where`, e.g. the flag) now, before a long render, if
    denoising cannot work: pyoidn missing, or its shared library (loaded on first use) missing or
    unloadable."""
    _oidn(where)
    try:
        _device()
    except (OSError, RuntimeError) as e:   # cffi's dlopen: OSError; a device OIDN cannot create
        raise DenoiserUnavailable(
            where, f"Intel Open Image Denoise cannot load its library ({e}); reinstall it: {INSTALL_HINT}") from None


def denoise(color, albedo=None, normal=None, prefilter=False, emission=None):
    """Denoised copy of the linear HDR `color` (H, W, 3); `albedo` in [0, 1] and `normal` in
    [-1, 1] (H, W, 3) guide it when given (normal only with albedo, as OIDN requires).
    `emission`: the part of `color` emitted towards the camera (the emission AOV), to keep out of
    the filter and add back: it has no lighting noise, and a bright emitter inside the filter's
    input comes out with a halo and noise of its own (docs/denoising.md)."""
    oidn = _oidn()
    if normal is not None and albedo is None:
        raise ArgumentError("normal", "needs an albedo image too (OIDN)")
    color = _float3(np.nan_to_num(np.asarray(color, dtype=np.float32)), "color")
    guides = {"emission": emission, "albedo": albedo, "normal": normal}
    guides = {name: _float3(image, name, color.shape) for name, image in guides.items() if image is not None}
    if emission is not None:
        emission = guides.pop("emission")
        color = color - emission
    images = {"color": np.maximum(color, 0.0)}
    if albedo is not None:
        images["albedo"] = np.clip(guides["albedo"], 0.0, 1.0)
    if normal is not None:
        images["normal"] = np.clip(guides["normal"], -1.0, 1.0)
    device = _device()
    if prefilter:
        for name in ("albedo", "normal"):
            if name in images:
                images[name] = _run_filter(oidn, device, {name: images[name]}, hdr=False,
                                           clean_aux=False, output_like=name)
    output = _run_filter(oidn, device, images, hdr=True, clean_aux=prefilter and len(images) > 1,
                         output_like="color")
    return output if emission is None else output + emission


def _float3(image, where, shape=None):
    """`image` as contiguous float32 (H, W, 3), of `shape` if given (ArgumentError naming `where`)."""
    image = np.ascontiguousarray(image, dtype=np.float32)
    if image.ndim != 3 or image.shape[2] != 3 or (shape is not None and image.shape != shape):
        expected = "an H x W x 3 image" if shape is None else f"a {shape[0]} x {shape[1]} x 3 image like color"
        raise ArgumentError(where, f"expected {expected}, got shape {image.shape}")
    return image


def _run_filter(oidn, device, images, hdr, clean_aux, output_like):
    """One execution of the RT filter on `images` (name -> array); returns its output."""
    height, width = images[output_like].shape[:2]
    top, left = max(0, MIN_SIDE - height) // 2, max(0, MIN_SIDE - width) // 2   # centred: OIDN is
    padding = ((top, max(0, MIN_SIDE - height) - top), (left, max(0, MIN_SIDE - width) - left), (0, 0))   # off at corners
    images = {name: np.pad(image, padding, mode="edge") for name, image in images.items()}
    output = np.empty_like(images[output_like])
    with oidn.Filter(device, oidn.OIDN_FILTER_TYPE_RT) as flt:
        for name, image in images.items():
            flt.set_image(name, image, oidn.OIDN_FORMAT_FLOAT3)
        flt.set_image(oidn.OIDN_IMAGE_OUTPUT, output, oidn.OIDN_FORMAT_FLOAT3)
        if "color" in images:
            flt.set_bool("hdr", hdr)
            flt.set_bool("cleanAux", clean_aux)
        flt.set_int("quality", oidn.OIDN_QUALITY_HIGH)
        flt.commit()
        flt.execute()
        error = device.get_error()
    if error is not None:
        raise DeviceError(f"Open Image Denoise failed: {error}")
    return np.ascontiguousarray(output[top:top + height, left:left + width])
