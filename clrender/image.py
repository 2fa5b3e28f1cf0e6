"""Image output and input. Output: tone-mapped sRGB PNG/JPEG/TIFF (imageio), linear float EXR
(OpenEXR). Input: every image clrender reads (environment maps, textures, EXR layers) through
OpenImageIO: PNG, JPEG, EXR, Radiance HDR, TGA, TIFF (and the other formats it knows).

Extra layers (AOVs, the noisy image beside a denoised one) go into the same EXR as channels
"<layer>.<channel>", the layout Blender and Nuke read (the colour itself is R, G, B); with 8-bit
formats each goes to its own file "<stem>.<layer><suffix>", mapped for viewing (ldr_layer).

Writes are atomic: a temporary file in the target folder, renamed over the target when complete,
so an interrupted or failed write never leaves a half-written image. `check_output_path` finds
the problems of a target before a render is spent on it.

Reading follows Mitsuba 3's bitmap texture: integer images (8 or 16 bits) are sRGB-encoded unless
read `raw`, float images (EXR, HDR, float TIFF) linear, whatever colour space the file names
(Mitsuba ignores PNG gamma chunks too); alpha is read unassociated, as stored, and dropped;
grey stays one channel; row 0 is the image's top row.
"""
import functools
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import limits
from .errors import ArgumentError, FileError
from .files import describe, not_a_file

LDR_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")
# EXR channel letters of a layer; others: R, G, B (three channels) or Y (one). "depth.Z" is
# Nuke's depth channel; normals are vectors, X, Y, Z as in Blender's Normal pass.
LAYER_CHANNELS = {"normal": "XYZ", "depth": "Z", "object_id": "X"}


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


def save_image(image, path, exposure=0.0, layers=None):
    """Save a linear HxWx3 float image; the format follows the suffix (.exr linear, else sRGB).
    `layers`: name -> (H, W) or (H, W, 3) array, written as EXR layers of the same file, or with
    8-bit formats as separate files (layer_path).

    Raises ArgumentError for a bad image, layer, suffix or exposure, FileError when a file cannot
    be written (nothing is left behind)."""
    path = Path(path)
    image = np.asarray(image, dtype=np.float32)
    if image.ndim != 3 or image.shape[2] != 3:
        raise ArgumentError("image", f"expected an HxWx3 image, got shape {image.shape}")
    layers = dict(layers or {})
    for name, layer in layers.items():
        if not (isinstance(name, str) and name and "/" not in name and "\\" not in name):
            raise ArgumentError("layers", "a layer name must be a non-empty string without slashes, "
                                          f"got {limits.show(name)}")
        if np.shape(layer)[:2] != image.shape[:2] or np.ndim(layer) not in (2, 3):
            raise ArgumentError(f"layers[{name!r}]", f"expected {image.shape[0]}x{image.shape[1]} pixels, "
                                                     f"got shape {np.shape(layer)}")
    suffix = path.suffix.lower()
    check_output_path(path)
    if suffix == ".exr":
        channels = {"RGB": np.ascontiguousarray(image)}
        channels.update(exr_layer_channels(layers))
        _atomic_write(path, lambda tmp: _write_exr(channels, tmp))
    else:
        for name in layers:   # every file's problems before the first is written
            check_output_path(layer_path(path, name))
        _write_ldr(tonemap(image, exposure), path)
        for name, layer in layers.items():
            _write_ldr(ldr_layer(name, layer, exposure), layer_path(path, name))


def save_display_image(pixels, path):
    """Save 8-bit display pixels (H, W, 3) uint8 as they are (already tone-mapped, e.g. what the
    viewer shows) to an 8-bit format; raises as save_image does."""
    path = Path(path)
    pixels = np.asarray(pixels)
    if pixels.dtype != np.uint8 or pixels.ndim != 3 or pixels.shape[2] != 3:
        raise ArgumentError("pixels", f"expected HxWx3 uint8 pixels, got {pixels.dtype} of shape {pixels.shape}")
    check_output_path(path)
    if path.suffix.lower() not in LDR_SUFFIXES:
        raise ArgumentError("path", f"display pixels go to an 8-bit format ({', '.join(LDR_SUFFIXES)}), not {path}")
    _write_ldr(pixels, path)


def layer_path(path, name):
    """Where an 8-bit output puts a layer: image.png -> image.albedo.png."""
    path = Path(path)
    return path.with_name(f"{path.stem}.{name}{path.suffix}")


def exr_layer_channels(layers):
    """EXR channels "<layer>.<channel>" -> float32 (H, W) for the layers."""
    channels = {}
    for name, layer in layers.items():
        layer = np.asarray(layer, dtype=np.float32)
        planes = layer[..., None] if layer.ndim == 2 else layer
        letters = LAYER_CHANNELS.get(name, "RGB" if planes.shape[2] == 3 else "Y")
        if len(letters) != planes.shape[2]:
            raise ArgumentError(f"layers[{name!r}]", f"expected {len(letters)} channels, got {planes.shape[2]}")
        for i, letter in enumerate(letters):
            channels[f"{name}.{letter}"] = np.ascontiguousarray(planes[..., i])
    return channels


def ldr_layer(name, layer, exposure=0.0):
    """An 8-bit view of a layer (exact values only in EXR): normals (n + 1) / 2; depth as grey,
    white at the nearest and black at the farthest hit and where nothing was hit; object ids as
    distinct colours (background black); variance as its square root, the standard error,
    tone-mapped like the image; albedo tone-mapped without exposure; others like the image."""
    layer = np.asarray(layer)
    if name == "normal":
        return np.round(np.clip((layer + 1.0) * 0.5, 0.0, 1.0) * 255.0).astype(np.uint8)
    if name == "depth":
        hit = np.isfinite(layer) & (layer > 0)
        near, far = (layer[hit].min(), layer[hit].max()) if hit.any() else (0.0, 1.0)
        grey = np.where(hit, 1.0 - 0.8 * (layer - near) / max(far - near, 1e-30), 0.0)
        return np.round(np.repeat(grey[..., None], 3, axis=2) * 255.0).astype(np.uint8)
    if name == "object_id":
        hue = (layer.astype(np.float64) * 0.618033988749895) % 1.0
        rgb = np.clip(np.abs(((hue[..., None] * 6.0 + np.array([0.0, 4.0, 2.0])) % 6.0) - 3.0) - 1.0, 0, 1)
        return np.round(np.where(layer[..., None] >= 0, 0.25 + 0.75 * rgb, 0.0) * 255.0).astype(np.uint8)
    if name == "variance":
        return tonemap(np.sqrt(np.maximum(layer, 0.0)), exposure)
    return tonemap(layer, 0.0 if name == "albedo" else exposure)


def _write_ldr(pixels, path):
    import imageio.v3 as iio

    _atomic_write(path, lambda tmp: iio.imwrite(tmp, pixels, extension=path.suffix.lower()))


def _write_exr(channels, path):
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    try:
        with OpenEXR.File(header, channels) as exr:
            exr.write(str(path))
    except RuntimeError as e:   # OpenEXR's for every failed write: a full disk, a file size limit
        raise OSError(str(e)) from None


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


@dataclass
class TextureImage:
    """An image as a texture reads it (load_texture_image)."""
    pixels: np.ndarray   # (H, W, C): C 1 (grey) or 3 (RGB); uint8 for 8-bit files, else float32
    srgb: bool           # sRGB-encoded values, to decode to linear at lookup (8-bit files unless raw)


def load_texture_image(path, raw=False):
    """An image file as Mitsuba's bitmap texture holds it: 8-bit images keep their bytes (sRGB-
    encoded unless `raw`: decoded at lookup, before interpolation, as Mitsuba does), 16-bit and
    other integer images become float32, sRGB-decoded unless `raw` (as Mitsuba decodes them on
    loading), float images stay linear float32. Alpha is dropped, grey stays one channel.
    Raises FileError naming the file when it is missing, unreadable, corrupt or too large."""
    pixels = _reading(path, _read_pixels)
    if pixels.dtype == np.uint8:
        return TextureImage(pixels, srgb=not raw)
    if pixels.dtype == np.uint16:
        pixels = (pixels * np.float32(1 / 65535)) if raw else _SRGB_16BIT()[pixels]
    return TextureImage(pixels, srgb=False)


def load_image(path):
    """An image as linear float32 H x W x 3 (environment maps): integer images sRGB-decoded, grey
    repeated into R, G, B, alpha dropped. Raises FileError naming the file when it is missing,
    unreadable, corrupt or too large."""
    texture = load_texture_image(path)
    pixels = _SRGB_8BIT[texture.pixels] if texture.srgb else texture.pixels
    return np.repeat(pixels, 3, axis=2) if pixels.shape[2] == 1 else pixels


def load_exr_layers(path):
    """The layers of an EXR written by save_image: name -> float32 (H, W, channels) in the
    channel order of LAYER_CHANNELS (R, G, B otherwise); the colour under the name "".
    Raises FileError when the file is missing or unreadable."""
    return _reading(path, _read_exr_layers)


def _read_exr_layers(path):
    with _opened(path) as (image, spec):
        pixels = _read(image, spec, "float")
    planes = dict(zip(spec.channelnames, np.moveaxis(pixels, 2, 0)))
    grouped = {}
    for name in planes:
        layer, _, letter = name.rpartition(".")
        grouped.setdefault(layer, []).append(letter)
    layers = {}
    for layer, letters in grouped.items():
        order = LAYER_CHANNELS.get(layer, "RGB" if sorted(letters) == ["B", "G", "R"] else "".join(sorted(letters)))
        prefix = f"{layer}." if layer else ""
        layers[layer] = np.stack([planes[prefix + letter] for letter in order], axis=-1)
    return layers


def _reading(path, read):
    """read(path) for an existing file, its failures as FileError."""
    if not isinstance(path, (str, os.PathLike)):
        raise ArgumentError("path", f"must be a file path, got {type(path).__name__}")
    path = Path(path)
    if not_a_file(path) is not None:   # a named pipe would block OpenImageIO's read
        raise FileError(describe(path, "image"))
    try:
        return read(path)
    except FileError:
        raise
    except Exception as e:   # OpenImageIO's messages for malformed files, numpy's for odd layouts
        raise FileError(f"cannot read image {path}: {e}") from None


def _read_pixels(path):
    """The colour channels of an image in their stored type: uint8, uint16, or float32 (floats,
    and integers of other widths, which OpenImageIO scales to [0, 1])."""
    with _opened(path) as (image, spec):
        names = [name.upper() for name in spec.channelnames]
        if all(letter in names for letter in "RGB"):
            chosen = [names.index(letter) for letter in "RGB"]
        elif "Y" in names:
            chosen = [names.index("Y")]
        else:   # unnamed: grey (and alpha), or colour (and alpha) first
            chosen = [0] if spec.nchannels < 3 else [0, 1, 2]
        kind = {"uint8": "uint8", "uint16": "uint16"}.get(str(spec.format), "float")
        first, last = min(chosen), max(chosen) + 1   # OpenImageIO reads a contiguous range
        pixels = _read(image, spec, kind, first, last)
    if chosen == list(range(first, last)):
        return pixels
    return np.ascontiguousarray(pixels[..., [c - first for c in chosen]])


class _opened:
    """`with _opened(path) as (image, spec)`: an OpenImageIO input on the first subimage, its
    size checked against the limits before anything is read; alpha left unassociated (as
    stored), as Mitsuba reads it."""

    def __init__(self, path):
        self.path = path

    def __enter__(self):
        import OpenImageIO as oiio   # 30 ms: only where an image is read

        config = oiio.ImageSpec()
        config.attribute("oiio:UnassociatedAlpha", 1)
        self.image = oiio.ImageInput.open(str(self.path), config)
        if self.image is None:
            raise ValueError(oiio.geterror() or "unknown format")
        spec = self.image.spec()
        if spec.deep or spec.depth > 1 or min(spec.width, spec.height, spec.nchannels) < 1:
            self.image.close()
            raise ValueError(f"not a flat 2D image ({spec.width} x {spec.height} x {spec.depth}, "
                             f"{spec.nchannels} channels)")
        if spec.width * spec.height * spec.nchannels > limits.MAX_IMAGE_VALUES:
            self.image.close()
            raise ValueError(f"{spec.width} x {spec.height} pixels of {spec.nchannels} channels, more than the "
                             f"{limits.MAX_IMAGE_VALUES} values clrender reads from an image")
        return self.image, spec

    def __exit__(self, *exc):
        self.image.close()


def _read(image, spec, kind, first=0, last=None):
    """Channels [first, last) of the whole image as numpy (H, W, C) of `kind`; ValueError with
    OpenImageIO's message when the data is corrupt or truncated (it may return pixels and only
    report the problem)."""
    pixels = image.read_image(0, 0, first, spec.nchannels if last is None else last, kind)
    if pixels is None or image.has_error:
        raise ValueError(image.geterror() or "unreadable pixel data")
    return pixels.reshape(spec.height, spec.width, -1)


def _srgb_table(levels):
    return srgb_to_linear(np.arange(levels) / (levels - 1)).astype(np.float32)


# sRGB decoding of every 8-bit value (and, made on first use, every 16-bit value).
_SRGB_8BIT = _srgb_table(256)
_SRGB_16BIT = functools.cache(lambda: _srgb_table(65536))
