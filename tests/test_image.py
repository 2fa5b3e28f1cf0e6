"""Image output: formats, tone mapping, atomic writes."""
import os
import stat

import numpy as np
import pytest

import clrender
from clrender import image as image_module
from clrender.image import load_exr_layers, load_image, save_image


def test_exr_round_trip_is_exact(tmp_path):
    pixels = np.random.default_rng(1).uniform(0, 50, (7, 5, 3)).astype(np.float32)
    clrender.save_image(pixels, tmp_path / "a.exr")
    assert np.array_equal(clrender.load_image(tmp_path / "a.exr"), pixels)


def test_png_is_srgb_encoded_and_clamped(tmp_path):
    pixels = np.array([[[0.0, 0.5, 2.0], [0.0031308, 1.0, -1.0]]], np.float32)
    clrender.save_image(pixels, tmp_path / "a.png")
    import imageio.v3 as iio
    stored = iio.imread(tmp_path / "a.png")
    assert stored[0, 0].tolist() == [0, 188, 255] and stored[0, 1].tolist() == [10, 255, 0]
    # one stop of exposure doubles the linear values before encoding
    clrender.save_image(pixels * 0.5, tmp_path / "b.png", exposure=1.0)
    assert np.array_equal(iio.imread(tmp_path / "b.png"), stored)


def test_failed_write_leaves_nothing_behind(tmp_path, monkeypatch):
    target = tmp_path / "out.exr"
    clrender.save_image(np.zeros((2, 2, 3)), target)
    before = target.read_bytes()

    def failing_write(image, path):
        open(path, "wb").write(b"partial")
        raise RuntimeError("disk full")

    monkeypatch.setattr(image_module, "_write_exr", failing_write)
    with pytest.raises(RuntimeError):
        clrender.save_image(np.ones((2, 2, 3)), target)
    assert target.read_bytes() == before          # the old file is untouched
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.exr"]  # no temporary left


def test_written_files_follow_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        clrender.save_image(np.zeros((2, 2, 3)), tmp_path / "a.png")
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(tmp_path / "a.png").st_mode) == 0o644


def test_unsupported_format_and_shape_are_rejected(tmp_path):
    with pytest.raises(ValueError, match="unsupported image format"):
        clrender.save_image(np.zeros((2, 2, 3)), tmp_path / "a.gif")
    with pytest.raises(ValueError, match="HxWx3"):
        clrender.save_image(np.zeros((2, 2)), tmp_path / "a.png")


def test_exr_layers_round_trip_through_the_openexr_reader(tmp_path):
    import OpenEXR

    rng = np.random.default_rng(3)
    image = rng.random((5, 7, 3), dtype=np.float32)
    layers = {"albedo": rng.random((5, 7, 3), dtype=np.float32),
              "normal": rng.uniform(-1, 1, (5, 7, 3)).astype(np.float32),
              "depth": np.where(rng.random((5, 7)) < 0.2, np.inf, rng.random((5, 7))).astype(np.float32),
              "object_id": rng.integers(-1, 9, (5, 7)).astype(np.int32)}
    path = tmp_path / "layers.exr"
    save_image(image, path, layers=layers)
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        channels = {name: channel.pixels for name, channel in exr.channels().items()}
    assert set(channels) == {"R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y",
                             "normal.Z", "depth.Z", "object_id.X"}
    for i, c in enumerate("RGB"):
        assert np.array_equal(channels[c], image[..., i])
        assert np.array_equal(channels[f"albedo.{c}"], layers["albedo"][..., i])
    for i, c in enumerate("XYZ"):
        assert np.array_equal(channels[f"normal.{c}"], layers["normal"][..., i])
    assert np.array_equal(channels["depth.Z"], layers["depth"])
    assert np.array_equal(channels["object_id.X"], layers["object_id"].astype(np.float32))
    loaded = load_exr_layers(path)
    assert np.array_equal(loaded[""], image) and np.array_equal(loaded["normal"], layers["normal"])
    assert np.array_equal(load_image(path), image)


def test_png_layers_go_to_separate_files(tmp_path):
    import imageio.v3 as iio

    image = np.full((4, 6, 3), 0.5, np.float32)
    normal = np.zeros((4, 6, 3), np.float32)
    normal[..., 2] = 1.0
    save_image(image, tmp_path / "out.png", layers={"normal": normal, "depth": np.full((4, 6), 2.0)})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.depth.png", "out.normal.png", "out.png"]
    assert np.all(iio.imread(tmp_path / "out.normal.png") == [128, 128, 255])
    with pytest.raises(ValueError, match="layer 'depth': expected 4x6 pixels"):
        save_image(image, tmp_path / "bad.exr", layers={"depth": np.zeros((3, 6))})
    assert not (tmp_path / "bad.exr").exists()
