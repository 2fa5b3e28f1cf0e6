"""Mitsuba 3's envmap lookup in numpy, from its definition (checked against Mitsuba by
tests/test_mitsuba_parity.py): the reference for the kernel's lookup "mitsuba" (kernels/lights.h)."""
import numpy as np


def mitsuba_envmap_lookup(image, directions):
    """Mitsuba's envmap value of the (H, W, C) `image` in directions (N, 3) of its own frame:
    bilinear between texel centres at u = (i + 0.5) / W, u = atan2(x, -z) / 2 pi (periodic: past
    the last centre the first is interpolated again) and rows at v = j / (H - 1) from +y."""
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    height, width = image.shape[:2]
    u = np.arctan2(d[:, 0], -d[:, 2]) * np.float32(1 / (2 * np.pi)) - np.float32(0.5 / width)
    column = (u - np.floor(u)) * width
    left = np.minimum(np.floor(column), width - 1).astype(int)
    right = np.where(left == width - 1, 0, left + 1)
    row = np.arccos(np.clip(d[:, 1], -1, 1)) * np.float32((height - 1) / np.pi)
    upper = np.minimum(np.floor(row), height - 2).astype(int)
    to_right, to_lower = (column - left)[:, None], (row - upper)[:, None]
    top = image[upper, left] * (1 - to_right) + image[upper, right] * to_right
    bottom = image[upper + 1, left] * (1 - to_right) + image[upper + 1, right] * to_right
    return top * (1 - to_lower) + bottom * to_lower
