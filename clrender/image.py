"""Image output and input: tone-mapped sRGB PNG (imageio), linear float EXR (OpenEXR).

Writes are atomic: a temporary file in the target folder, renamed over the target when complete,
so an interrupted or failed write never leaves a half-written image.
"""
import os
import tempfile
from pathlib import Path

import numpy as np

LDR_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")


def linear_to_srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def srgb_to_linear(x):
    return np.where(x <= 0.04045, x / 12.92, np.power((x + 0.055) / 1.055, 2.4))


def tonemap(image, exposure=0.0):
    """Linear radiance -> 8-bit sRGB: exposure in stops, clamp, sRGB transfer curve."""
    scaled = np.nan_to_num(image, nan=0.0, posinf=1.0) * (2.0 ** exposure)
    return np.round(linear_to_srgb(scaled) * 255.0).astype(np.uint8)


def save_image(image, path, exposure=0.0):
    """Save a linear HxWx3 float image; the format follows the suffix (.exr linear, else sRGB)."""
    path = Path(path)
    image = np.asarray(image, dtype=np.float32)
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"expected an HxWx3 image, got shape {image.shape}")
    suffix = path.suffix.lower()
    if suffix == ".exr":
        _atomic_write(path, lambda tmp: _write_exr(image, tmp))
    elif suffix in LDR_SUFFIXES:
        import imageio.v3 as iio

        pixels = tonemap(image, exposure)
        _atomic_write(path, lambda tmp: iio.imwrite(tmp, pixels, extension=suffix))
    else:
        raise ValueError(f"unsupported image format {suffix!r}; use .exr or one of {', '.join(LDR_SUFFIXES)}")


def _write_exr(image, path):
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(image)}) as exr:
        exr.write(str(path))


def _atomic_write(path, write):
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        # mkstemp makes the file private (0600); give it the permissions a plain open() would.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def load_image(path):
    """Read an image as linear float32 HxWx3 (EXR as stored; 8-bit formats sRGB-decoded)."""
    path = Path(path)
    if path.suffix.lower() == ".exr":
        import OpenEXR

        with OpenEXR.File(str(path)) as exr:
            channels = exr.channels()
            if "RGB" in channels:
                pixels = channels["RGB"].pixels
            elif "RGBA" in channels:
                pixels = channels["RGBA"].pixels[..., :3]
            else:
                raise ValueError(f"no RGB channels in {path} (has {', '.join(channels)})")
        return np.asarray(pixels, dtype=np.float32)
    import imageio.v3 as iio

    pixels = np.asarray(iio.imread(path))
    if pixels.ndim == 2:
        pixels = np.repeat(pixels[..., None], 3, axis=2)
    pixels = pixels[..., :3]
    if np.issubdtype(pixels.dtype, np.integer):
        return srgb_to_linear(pixels.astype(np.float32) / np.iinfo(pixels.dtype).max).astype(np.float32)
    return pixels.astype(np.float32)
