"""The viewer's tone maps: linear radiance -> 8-bit sRGB with an exposure in stops and a curve.

The page applies them itself (static/viewer.js, `toneMap`), so moving the exposure needs no new
frame; the saved PNG is made here by the same formulas (the browser tests compare the two).
    clamp     clip to [0, 1]: the curve of `clrender render`'s 8-bit images (image.tonemap)
    reinhard  x / (1 + x) per channel: highlights compressed, never clipped
    aces      Narkowicz's fit of the ACES filmic curve: (x (2.51 x + 0.03)) / (x (2.43 x + 0.59) + 0.14)
"""
import numpy as np

from .. import limits
from ..errors import ArgumentError
from ..image import tonemap


def _clamp(x):
    return x


def _reinhard(x):
    x = np.maximum(x, 0.0)
    return x / (1.0 + x)


def _aces(x):
    x = np.maximum(x, 0.0)
    return x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14)


CURVES = {"clamp": _clamp, "reinhard": _reinhard, "aces": _aces}
TONE_MAPS = tuple(CURVES)


def tone_map(image, exposure=0.0, curve="clamp"):
    """(H, W, 3) linear radiance -> uint8 sRGB: non-finite values as image.tonemap takes them
    (NaN 0, +inf 1), times 2^exposure, through `curve`, clipped to [0, 1], sRGB-encoded."""
    if curve not in CURVES:
        raise ArgumentError("tonemap", f"unknown tone map {limits.show(curve)}; valid: {', '.join(TONE_MAPS)}")
    exposure = limits.setting("exposure", exposure)
    with np.errstate(over="ignore"):   # -inf comes in as the lowest float32: it may overflow, to black
        scaled = np.nan_to_num(np.asarray(image, np.float32), nan=0.0, posinf=1.0) * np.float32(2.0 ** exposure)
        return tonemap(CURVES[curve](scaled))
