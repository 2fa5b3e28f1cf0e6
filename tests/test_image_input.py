"""Image input through OpenImageIO: textures hold what Mitsuba 3's bitmap texture holds (bytes of
8-bit files, sRGB-decoded 16-bit files, linear floats, alpha dropped, grey kept grey) and look up
to its values; environment maps are linear RGB; bad files are errors naming the file, checked
for size before anything is read."""
import glob
import os
import struct
import tracemalloc
import zlib
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

import clrender
from clrender.image import load_image, load_texture_image, srgb_to_linear

try:
    import mitsuba as mi
except ImportError:
    mi = None
needs_mitsuba = pytest.mark.skipif(mi is None, reason="Mitsuba 3 is not installed (pip install -e '.[peers]')")
REAL_SCENES = Path(os.environ.get("CLRENDER_REAL_SCENES", "/work/shared/real-scenes"))


def write_image(path, pixels, kind):
    """`pixels` (H, W, C) written with OpenImageIO as `kind` ("uint8", "uint16", "half",
    "float"); alpha as given (unassociated)."""
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], kind)
    spec.attribute("oiio:UnassociatedAlpha", 1)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec), oiio.geterror()
    assert out.write_image(pixels), out.geterror()
    out.close()
    return path


def random_pixels(shape, kind, seed=0):
    rng = np.random.default_rng(seed)
    if kind == "uint8":
        return rng.integers(0, 256, shape, dtype=np.uint8)
    if kind == "uint16":
        return rng.integers(0, 65536, shape, dtype=np.uint16)
    return rng.uniform(0, 4, shape).astype(np.float32)   # beyond 1: radiance


# (file name, channels, stored type): every format and layout the reader must handle.
GENERATED = [("rgb.png", 3, "uint8"), ("rgba.png", 4, "uint8"), ("grey.png", 1, "uint8"),
             ("grey_alpha.png", 2, "uint8"), ("rgb16.png", 3, "uint16"), ("rgb.jpg", 3, "uint8"),
             ("rgb.exr", 3, "float"), ("rgba_half.exr", 4, "half"), ("rgb.hdr", 3, "float"),
             ("rgb.tga", 3, "uint8"), ("rgba.tga", 4, "uint8")]


def generated(tmp_path, name, channels, kind):
    return write_image(tmp_path / name, random_pixels((5, 7, channels), kind), kind)


def linear_texels(texture):
    """The linear values a lookup decodes from a TextureImage."""
    pixels = texture.pixels.astype(np.float64) / (255 if texture.pixels.dtype == np.uint8 else 1)
    return srgb_to_linear(pixels) if texture.srgb else pixels


def mitsuba_texels(path, raw):
    """Mitsuba's bitmap texture evaluated at every texel centre (nearest filter), (H, W, 3)."""
    mi.set_variant("scalar_rgb")
    texture = mi.load_dict({"type": "bitmap", "filename": str(path), "raw": raw, "filter_type": "nearest"})
    height, width = np.array(mi.traverse(texture)["data"]).shape[:2]
    si = mi.SurfaceInteraction3f()
    values = np.zeros((height, width, 3))
    for j in range(height):
        for i in range(width):
            si.uv = [(i + 0.5) / width, (j + 0.5) / height]
            values[j, i] = np.array(texture.eval(si))
    return values


def assert_as_mitsuba(path, raw):
    """Our texture's stored texels equal Mitsuba's (bytes exactly; 16-bit files, which Mitsuba
    keeps in float16, to its precision) and decode to the values Mitsuba's lookup returns."""
    ours = load_texture_image(path, raw)
    mi.set_variant("scalar_rgb")
    stored = np.array(mi.traverse(mi.load_dict({"type": "bitmap", "filename": str(path), "raw": raw}))["data"])
    assert ours.pixels.shape == stored.shape and ours.pixels.dtype == (np.uint8 if stored.dtype == np.uint8 else np.float32)
    if stored.dtype == np.float16:
        np.testing.assert_allclose(ours.pixels, stored, rtol=1e-3, atol=1e-6)
    else:
        np.testing.assert_array_equal(ours.pixels, stored)
    linear = linear_texels(ours)
    theirs = mitsuba_texels(path, raw)
    np.testing.assert_allclose(np.broadcast_to(linear, theirs.shape), theirs, rtol=2e-6 if stored.dtype != np.float16 else 1e-3,
                               atol=1e-7)


@needs_mitsuba
@pytest.mark.parametrize("raw", [False, True])
@pytest.mark.parametrize("name, channels, kind", GENERATED, ids=[g[0] for g in GENERATED])
def test_textures_hold_and_look_up_what_mitsubas_bitmap_does(tmp_path, name, channels, kind, raw):
    assert_as_mitsuba(generated(tmp_path, name, channels, kind), raw)


def real_textures():
    found = sorted(glob.glob(str(REAL_SCENES / "*" / "textures" / "*"))) + sorted(
        glob.glob(str(REAL_SCENES / "*" / "common" / "textures" / "*.exr")))[:1]
    return [f for f in found if Path(f).suffix.lower() in (".png", ".jpg", ".exr")] or [
        pytest.param(None, marks=pytest.mark.skip(reason=f"no textures under {REAL_SCENES}"))]


@needs_mitsuba
@pytest.mark.parametrize("path", real_textures(), ids=lambda p: Path(p).name if p else "none")
def test_real_textures_are_mitsubas(path):
    ours = load_texture_image(path)
    mi.set_variant("scalar_rgb")
    stored = np.array(mi.traverse(mi.load_dict({"type": "bitmap", "filename": path}))["data"])
    assert ours.srgb == (stored.dtype == np.uint8)
    np.testing.assert_array_equal(ours.pixels, stored.astype(ours.pixels.dtype))   # float16 files: exact in float32


def test_texture_types_and_encodings(tmp_path):
    """8-bit: bytes, sRGB unless raw; 16-bit: float32 decoded unless raw; floats: linear."""
    eight = generated(tmp_path, "a.png", 3, "uint8")
    texture = load_texture_image(eight)
    assert texture.pixels.dtype == np.uint8 and texture.srgb and not load_texture_image(eight, raw=True).srgb
    sixteen = tmp_path / "b.png"
    values = random_pixels((5, 7, 3), "uint16")
    write_image(sixteen, values, "uint16")
    decoded, raw = load_texture_image(sixteen), load_texture_image(sixteen, raw=True)
    assert decoded.pixels.dtype == raw.pixels.dtype == np.float32 and not decoded.srgb and not raw.srgb
    np.testing.assert_allclose(raw.pixels, values / 65535, rtol=1e-6)
    np.testing.assert_allclose(decoded.pixels, srgb_to_linear(values / 65535), rtol=1e-6, atol=1e-9)
    exr = generated(tmp_path, "c.exr", 4, "float")
    texture = load_texture_image(exr)
    assert texture.pixels.dtype == np.float32 and not texture.srgb and texture.pixels.shape == (5, 7, 3)


def test_row_zero_is_the_top_row_in_every_format(tmp_path):
    pixels = np.zeros((4, 3, 3), np.uint8)
    pixels[0] = 250                                        # a white top row
    for name in ("a.png", "a.jpg", "a.tga", "a.tif", "a.exr", "a.hdr"):
        kind = "float" if name.endswith(("exr", "hdr")) else "uint8"
        write_image(tmp_path / name, pixels.astype(np.float32) / 255 if kind == "float" else pixels, kind)
        texture = load_texture_image(tmp_path / name)
        assert texture.pixels[0].min() > texture.pixels[-1].max(), name


def test_environment_maps_are_linear_rgb(tmp_path):
    rgb = random_pixels((4, 8, 3), "float")
    write_image(tmp_path / "sky.hdr", rgb, "float")
    hdr = load_image(tmp_path / "sky.hdr")
    assert hdr.dtype == np.float32 and hdr.shape == (4, 8, 3)
    # RGBE: 8 bits of mantissa under an exponent shared by the pixel's channels.
    assert np.all(np.abs(hdr - rgb) <= rgb.max(axis=2, keepdims=True) / 128)
    grey = random_pixels((4, 8, 2), "uint8")
    write_image(tmp_path / "grey.png", grey, "uint8")
    np.testing.assert_allclose(load_image(tmp_path / "grey.png"), np.repeat(srgb_to_linear(grey[..., :1] / 255), 3, axis=2),
                               rtol=1e-6)


def test_hdr_environment_maps_load_in_a_scene(tmp_path):
    write_image(tmp_path / "sky.hdr", random_pixels((4, 8, 3), "float"), "float")
    scene = clrender.load_scene_dict({"camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
                                      "materials": [], "shapes": [],
                                      "lights": [{"type": "environment", "file": "sky.hdr"}]}, base_dir=tmp_path)
    np.testing.assert_allclose(scene.environment.image, load_image(tmp_path / "sky.hdr"))


def png_claiming(width, height):
    """A PNG whose header claims width x height RGBA pixels, with a tiny (wrong) body."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    header = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b"")


@pytest.mark.parametrize("name, content, message", [
    ("missing.png", None, "image not found: "),
    ("garbage.png", b"\x89PNG\r\n\x1a\n" + b"garbage" * 10, "cannot read image "),
    ("text.exr", b"not an exr file", "cannot read image "),
    ("unknown.xyz", b"\0" * 100, "cannot read image "),
    ("huge.png", png_claiming(60000, 60000), "png header claims a 13732 MB image from a 69 byte file"),
], ids=["missing", "garbage", "not-exr", "unknown", "huge"])
def test_bad_images_are_file_errors_naming_the_file_in_bounded_memory(tmp_path, name, content, message):
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    tracemalloc.start()
    try:
        with pytest.raises(clrender.FileError) as error:
            load_texture_image(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert message in str(error.value) and str(path) in str(error.value)
    assert peak < 8 * 2**20


def test_images_beyond_the_limit_are_refused_before_reading(tmp_path, monkeypatch):
    from clrender import limits

    path = generated(tmp_path, "a.png", 4, "uint8")
    monkeypatch.setattr(limits, "MAX_IMAGE_VALUES", 5 * 7 * 4 - 1)
    monkeypatch.setattr(oiio.ImageInput, "read_image", lambda *args: pytest.fail("pixels were read"))
    with pytest.raises(clrender.FileError, match=f"cannot read image {path}: 7 x 5 pixels of 4 channels, more "
                                                 "than the 139 values clrender reads from an image"):
        load_texture_image(path)


@pytest.mark.parametrize("name, cut", [("a.jpg", 0.5), ("a.png", 0.6), ("a.exr", 0.5)])
def test_truncated_images_are_file_errors(tmp_path, name, cut):
    kind = "float" if name.endswith("exr") else "uint8"
    path = write_image(tmp_path / name, random_pixels((64, 64, 3), kind), kind)
    path.write_bytes(path.read_bytes()[:int(cut * path.stat().st_size)])
    with pytest.raises(clrender.FileError, match=f"cannot read image {path}"):
        load_image(path)


def test_bad_environment_file_is_a_scene_error_naming_the_field(tmp_path):
    (tmp_path / "sky.hdr").write_bytes(b"#?RADIANCE\nnonsense")
    with pytest.raises(clrender.SceneError, match=r"lights\[0\]\.file: cannot read image .*sky\.hdr"):
        clrender.load_scene_dict({"camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]}, "materials": [],
                                  "shapes": [], "lights": [{"type": "environment", "file": "sky.hdr"}]},
                                 base_dir=tmp_path)
