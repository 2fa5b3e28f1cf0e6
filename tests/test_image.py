"""Image output: formats, tone mapping, atomic writes."""
import os
import stat

import numpy as np
import pytest

import clrender
from clrender import image as image_module


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
