"""Image output and input: tone-mapped sRGB PNG (imageio), linear float EXR (OpenEXR).

Writes are atomic: a temporary file in the target folder, renamed over the target when complete,
so an interrupted or failed write never leaves a half-written image. `check_output_path` finds
the problems of a target before a render is spent on it.
"""
import os
import tempfile
from pathlib import Path

import numpy as np

from . import limits
from .errors import ArgumentError, FileError

LDR_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")


def check_output_path(path, where="path"):
    """Raise unless an image can be written at `path`: a supported suffix (ArgumentError), not a
    folder, and its folder either writable or creatable in a writable folder (FileError).
    Creates nothing: the folders are made when the image is saved."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix != ".exr" and suffix not in LDR_SUFFIXES:
        raise ArgumentError(where, (f"unsupported image format {suffix!r}" if suffix else "no image format suffix")
                            + f" in {path}; use .exr or one of {', '.join(LDR_SUFFIXES)}")
    if path.is_dir():
        raise FileError(f"cannot write {path}: it is a directory")
    folder = path.parent
    while not folder.exists():
        if folder.is_symlink():
            raise FileError(f"cannot write {path}: {folder} is a broken link")
        folder = folder.parent
    if not folder.is_dir():
        raise FileError(f"cannot write {path}: {folder} is not a directory")
    try:   # the only reliable test (permissions, read-only file systems, root): try it
        fd, probe = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".probe", dir=folder)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise FileError(f"cannot write {path}: {folder}: {e.strerror or e}") from None


def linear_to_srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def srgb_to_linear(x):
    return np.where(x <= 0.04045, x / 12.92, np.power((x + 0.055) / 1.055, 2.4))


def tonemap(image, exposure=0.0):
    """Linear radiance -> 8-bit sRGB: exposure in stops, clamp, sRGB transfer curve."""
    exposure = limits.setting("exposure", exposure)
    scaled = np.nan_to_num(image, nan=0.0, posinf=1.0) * (2.0 ** exposure)
    return np.round(linear_to_srgb(scaled) * 255.0).astype(np.uint8)


def save_image(image, path, exposure=0.0):
    """Save a linear HxWx3 float image; the format follows the suffix (.exr linear, else sRGB).

    Raises ArgumentError for a bad image, suffix or exposure, FileError when the file cannot be
    written (nothing is left behind)."""
    path = Path(path)
    image = np.asarray(image, dtype=np.float32)
    if image.ndim != 3 or image.shape[2] != 3:
        raise ArgumentError("image", f"expected an HxWx3 image, got shape {image.shape}")
    suffix = path.suffix.lower()
    check_output_path(path)
    if suffix == ".exr":
        _atomic_write(path, lambda tmp: _write_exr(image, tmp))
    else:
        import imageio.v3 as iio

        pixels = tonemap(image, exposure)
        _atomic_write(path, lambda tmp: iio.imwrite(tmp, pixels, extension=suffix))


def _write_exr(image, path):
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(image)}) as exr:
        exr.write(str(path))


def _atomic_write(path, write):
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    except OSError as e:
        raise FileError(f"cannot write {path}: {e.strerror or e}") from None
    os.close(fd)
    try:
        write(tmp)
        # mkstemp makes the file private (0600); give it the permissions a plain open() would.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except OSError as e:
        os.unlink(tmp)
        raise FileError(f"cannot write {path}: {e.strerror or e}") from None
    except BaseException:
        os.unlink(tmp)
        raise


def load_image(path):
    """Read an image as linear float32 HxWx3 (EXR as stored; 8-bit formats sRGB-decoded).
    Raises FileError when the file is missing or unreadable."""
    path = Path(path)
    if not path.is_file():
        raise FileError(f"image not found: {path}" if not path.exists() else f"not a file: {path}")
    try:
        return _read_image(path)
    except FileError:
        raise
    except Exception as e:   # the image libraries raise many types for malformed files
        raise FileError(f"cannot read image {path}: {e}") from None


def _read_image(path):
    if path.suffix.lower() == ".exr":
        import OpenEXR

        with OpenEXR.File(str(path)) as exr:
            channels = exr.channels()
            if "RGB" in channels:
                pixels = channels["RGB"].pixels
            elif "RGBA" in channels:
                pixels = channels["RGBA"].pixels[..., :3]
            else:
                raise FileError(f"no RGB channels in {path} (has {', '.join(channels)})")
        return np.asarray(pixels, dtype=np.float32)
    import imageio.v3 as iio

    pixels = np.asarray(iio.imread(path))
    if pixels.ndim == 2:
        pixels = np.repeat(pixels[..., None], 3, axis=2)
    pixels = pixels[..., :3]
    if np.issubdtype(pixels.dtype, np.integer):
        return srgb_to_linear(pixels.astype(np.float32) / np.iinfo(pixels.dtype).max).astype(np.float32)
    return pixels.astype(np.float32)
