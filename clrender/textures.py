"""Textures: what a material parameter may take its value from instead of a constant.

Two kinds, with Mitsuba 3's definitions (docs/scene-format.md, Textures):
  bitmap        an image looked up at uv: `filter` bilinear (between texel centres, at
                (i + 0.5) / width) or nearest; `wrap` repeat, mirror or clamp (of texel
                indices); 8-bit images are sRGB-encoded unless `raw` (decoded to linear before
                filtering), float images linear; 1, 3 or 4 channels (alpha is not colour).
  checkerboard  color0 where the fractional parts of u and v are both above or both below 0.5,
                else color1.
Both map the surface's uv by `to_uv` (an affine 2x3 matrix) first. Image row 0 is v = 0.

On the device (kernels/textures/texture.h) a texture is a small record (layout.TEXTURE) and
the texels of every bitmap share one byte buffer, each stored as it came (8-bit stays 8-bit,
float32 aligned to 4 bytes). `lookup` here is the reference the kernel is tested against.
"""
import sys
from dataclasses import dataclass, field

import numpy as np

from . import disk_cache, host_memory, layout, principled

KINDS = tuple(layout.TEXTURE_KINDS)
FILTERS = tuple(layout.TEXTURE_FILTERS)
WRAPS = tuple(layout.TEXTURE_WRAPS)
# Mitsuba's luminance of linear RGB (eval_1 of a colour texture).
LUMINANCE = np.array([0.212671, 0.715160, 0.072169])
MAX_TEXELS_BYTES = 2**31 - 1   # byte offsets into the texel buffer are int32
_MEAN_BLOCK = 1 << 14   # texels decoded at a time by Texture.mean (a few hundred kB)


@dataclass
class Texture:
    name: str
    type: str                          # "bitmap" or "checkerboard"
    pixels: np.ndarray = None          # bitmap: (H, W, C), C in 1, 3, 4; uint8 or float32
    srgb: bool = False                 # bitmap: 8-bit values are sRGB-encoded (decoded at lookup)
    filter: str = "bilinear"
    wrap: str = "repeat"
    to_uv: np.ndarray = field(default_factory=lambda: np.eye(3)[:2])   # (2, 3) affine map of uv
    color0: np.ndarray = field(default_factory=lambda: np.full(3, 0.4))
    color1: np.ndarray = field(default_factory=lambda: np.full(3, 0.2))
    source: str = ""                   # the file it came from, for messages
    # (pixels, srgb, mean()): the value and the pixels array and encoding it was computed for (a
    # texture's pixels are replaced, not edited in place, to change it).
    _mean: tuple = field(default=None, repr=False, compare=False)

    @property
    def channels(self):
        return 3 if self.pixels is None else self.pixels.shape[2]

    def mean(self):
        """The texture's mean linear RGB over its [0, 1]^2 tile (a checkerboard's is the mean of its
        two colours): the weight of an emitter it drives."""
        if self.type == "checkerboard":
            return (np.asarray(self.color0, float) + np.asarray(self.color1, float)) / 2
        if self._mean is None or self._mean[0] is not self.pixels or self._mean[1] != self.srgb:
            self._mean = (self.pixels, self.srgb, self._stored_bitmap_mean())
        return self._mean[2]

    def _stored_bitmap_mean(self):
        # Computed once per image: hashing the texels is 8 times faster than summing them
        # (the staircase's 18 M texels: 0.04 s against 0.38 s).
        entry = disk_cache.key("bitmap mean", disk_cache.code_digest(sys.modules[__name__]), self.srgb,
                               disk_cache.array_digest(self.pixels))
        stored = disk_cache.load("means", entry, (3,))
        if stored is not None:
            return stored.copy()
        mean = self._bitmap_mean()
        disk_cache.store("means", entry, mean)
        return mean

    def _bitmap_mean(self):
        # numpy's float32 mean over the texels, rgb.reshape(-1, 3).mean(axis=0), adds them row
        # after row: the same running sum here, block by block (the total carried in each
        # block's first row), without decoding the whole image into a float32 copy.
        texels = self.pixels.reshape(-1, self.channels)
        rows = np.empty((_MEAN_BLOCK + 1, 3), np.float32)
        total = np.zeros(3, np.float32)
        for start in range(0, len(texels), _MEAN_BLOCK):
            block = texels[start:start + _MEAN_BLOCK]
            rows[0] = total
            rows[1:len(block) + 1] = _as_rgb(_linear(block, self.srgb))
            total = rows[:len(block) + 1].sum(axis=0)
        return total / len(texels)

    def number_range(self):
        """The least and the largest number (lookup_number) the texture takes: filtering keeps
        within its texels' (a checkerboard's colours') values."""
        if self.type == "checkerboard":
            values = np.array([self.color0, self.color1], float) @ LUMINANCE
        elif self.channels == 1:
            values = _linear(self.pixels, self.srgb)
        else:
            values = _as_rgb(_linear(self.pixels, self.srgb)) @ LUMINANCE
        return float(values.min()), float(values.max())


def srgb_to_linear(x):
    """sRGB-encoded values in [0, 1] to linear (IEC 61966-2-1)."""
    x = np.asarray(x, dtype=np.float64)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def srgb8_table():
    """The linear value of each 8-bit sRGB code, as float32 (the kernel's decoding table)."""
    return srgb_to_linear(np.arange(256) / 255.0).astype(np.float32)


def _linear(pixels, srgb):
    """Texel values as linear float32, as the device decodes them."""
    if pixels.dtype == np.uint8:
        return srgb8_table()[pixels] if srgb else (pixels / np.float32(255)).astype(np.float32)
    return pixels.astype(np.float32)


def _as_rgb(values):
    """(..., C) texel values as RGB: grey repeated, alpha dropped."""
    return np.repeat(values, 3, axis=-1) if values.shape[-1] == 1 else values[..., :3]


def _wrap(index, size, mode):
    if mode == "repeat":
        return np.mod(index, size)
    if mode == "mirror":
        index = np.mod(index, 2 * size)
        return np.where(index >= size, 2 * size - index - 1, index)
    return np.clip(index, 0, size - 1)


def _st(texture, uv):
    uv = np.asarray(uv, dtype=np.float64)
    return uv @ texture.to_uv[:, :2].T + texture.to_uv[:, 2]


def _bilinear_texels(texture, values, st):
    """The four texels that bilinear filtering blends at st, (v00, v10, v01, v11), and the
    weights (fx, fy) of the second ones."""
    height, width = values.shape[:2]
    x, y = st[..., 0] * width - 0.5, st[..., 1] * height - 0.5
    i0, j0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    fx, fy = (x - i0)[..., None], (y - j0)[..., None]
    i1, j1 = _wrap(i0 + 1, width, texture.wrap), _wrap(j0 + 1, height, texture.wrap)
    i0, j0 = _wrap(i0, width, texture.wrap), _wrap(j0, height, texture.wrap)
    return (values[j0, i0], values[j0, i1], values[j1, i0], values[j1, i1]), (fx, fy)


def _texel_values(texture):
    return _as_rgb(_linear(texture.pixels, texture.srgb)).astype(np.float64)


def _checkerboard_first(st):
    """Whether st lies in a check of color0."""
    upper = (st - np.floor(st)) > 0.5
    return upper[..., 0] == upper[..., 1]


def lookup(texture, uv):
    """Linear RGB of `texture` at surface uv (..., 2): the reference of textures/texture.h."""
    st = _st(texture, uv)
    if texture.type == "checkerboard":
        return np.where(_checkerboard_first(st)[..., None], np.asarray(texture.color0, float),
                        np.asarray(texture.color1, float))
    values = _texel_values(texture)
    height, width = values.shape[:2]
    if texture.filter == "nearest":
        i = _wrap(np.floor(st[..., 0] * width).astype(np.int64), width, texture.wrap)
        j = _wrap(np.floor(st[..., 1] * height).astype(np.int64), height, texture.wrap)
        return values[j, i]
    (v00, v10, v01, v11), (fx, fy) = _bilinear_texels(texture, values, st)
    return (v00 * (1 - fx) + v10 * fx) * (1 - fy) + (v01 * (1 - fx) + v11 * fx) * fy


def _as_number(texture, rgb):
    """RGB values as numbers: a one-channel bitmap's value, else the luminance."""
    if texture.type == "bitmap" and texture.channels == 1:
        return rgb[..., 0]
    return rgb @ LUMINANCE


def lookup_number(texture, uv):
    """The texture as a number at uv, as Mitsuba 3.9's eval_1: a one-channel bitmap's value, an
    RGB bitmap's luminance, a checkerboard the channel mean of the *other* check's colour (its
    eval_1 swaps the colours against eval)."""
    if texture.type == "checkerboard":
        first = _checkerboard_first(_st(texture, uv))
        return np.where(first, np.mean(texture.color1), np.mean(texture.color0))
    return _as_number(texture, lookup(texture, uv))


def lookup_number_gradient(texture, uv):
    """The gradient of lookup_number with respect to uv (..., 2), as Mitsuba 3.9's eval_1_grad
    defines it: the derivative of the bilinear interpolant within its cell, 0 for nearest
    filtering and checkerboards (Mitsuba has none for checkerboards); texel differences are
    multiplied by the transposed to_uv, then by the resolution per axis."""
    uv = np.asarray(uv, dtype=np.float64)
    if texture.type == "checkerboard" or texture.filter == "nearest":
        return np.zeros(uv.shape)
    values = _texel_values(texture)
    height, width = values.shape[:2]
    (f00, f10, f01, f11), (fx, fy) = _bilinear_texels(texture, values, _st(texture, uv))
    f00, f10, f01, f11 = (_as_number(texture, f)[..., None] for f in (f00, f10, f01, f11))
    dx = (1 - fy) * (f10 - f00) + fy * (f11 - f01)
    dy = (1 - fx) * (f01 - f00) + fx * (f11 - f10)
    matrix = texture.to_uv[:, :2]
    return np.concatenate([width * (matrix[0, 0] * dx + matrix[1, 0] * dy),
                           height * (matrix[0, 1] * dx + matrix[1, 1] * dy)], axis=-1)


def texture_arrays(textures):
    """(records, texels): the layout.TEXTURE record of each texture and the byte buffer holding
    every bitmap's texels (one dummy byte without any)."""
    records = np.zeros(max(len(textures), 1), layout.TEXTURE)
    chunks, offset = [], 0
    for index, texture in enumerate(textures):
        record = records[index]
        record["info"][0] = layout.TEXTURE_KINDS[texture.type]
        record["format"][2] = layout.TEXTURE_FILTERS[texture.filter]
        record["format"][3] = layout.TEXTURE_WRAPS[texture.wrap]
        record["to_uv_u"][:3] = texture.to_uv[0]
        record["to_uv_v"][:3] = texture.to_uv[1]
        record["color0"][:3] = texture.color0
        record["color1"][:3] = texture.color1
        if texture.pixels is None:
            continue
        height, width, channels = texture.pixels.shape
        if texture.pixels.dtype == np.uint8:
            encoding = "srgb8" if texture.srgb else "linear8"
            data = np.ascontiguousarray(texture.pixels).view(np.uint8).ravel()
        else:
            encoding = "float32"
            offset += -offset % 4   # float texels are read as floats: 4-byte aligned
            data = np.ascontiguousarray(texture.pixels, dtype=np.float32).view(np.uint8).ravel()
        if offset + data.size > MAX_TEXELS_BYTES:
            raise ValueError(f"textures hold more than {MAX_TEXELS_BYTES} bytes of texels")
        record["info"][1:] = (offset, width, height)
        record["format"][:2] = (channels, layout.TEXEL_ENCODINGS[encoding])
        chunks.append((offset, data))
        offset += data.size
    texels = host_memory.zeros(max(offset, 1), np.uint8)
    for start, data in chunks:
        texels[start:start + data.size] = data
    return records, texels


def srgb8_header():
    """The text of kernels/textures/srgb8.h: srgb8_table() as a C array (tests compare the two)."""
    values = [repr(float(v)) + "f" for v in srgb8_table()]
    rows = ",\n".join("    " + ", ".join(values[i:i + 6]) for i in range(0, 256, 6))
    return ("// The linear value of each 8-bit sRGB code (IEC 61966-2-1), as float32: 8-bit sRGB textures are\n"
            "// stored as they came and decoded texel by texel, before filtering (as Mitsuba does).\n"
            "// Generated by clrender.textures.srgb8_header(); tests/test_textures.py checks it.\n"
            "#ifndef CLRENDER_SRGB8_H\n#define CLRENDER_SRGB8_H\n\n"
            f"__constant float SRGB8_TO_LINEAR[256] = {{\n{rows}\n}};\n\n#endif\n")


def scene_uses_textures(scene):
    """Whether a material that some shape shows takes a parameter from a texture, lets light
    through, bends its shading normal, has a back material, or has lobes that depend on the
    tangent (an anisotropic principled material): the surface detail the TEXTURES feature
    compiles (clrender/features.py), with uv and dp/du at the scene's hits."""
    return any(has_surface_detail(m) for m in scene.used_materials())


def has_surface_detail(material):
    """Textured parameters, or detail_beyond_textures."""
    return bool(material.textures) or detail_beyond_textures(material)


def lets_light_through(material):
    """A mask: an opacity below 1, or one from a texture."""
    return material.opacity < 1 or "opacity" in material.textures


def detail_beyond_textures(material, masks=True):
    """An opacity below 1 (if `masks`), a bump or normal map, a back material, or tangent-dependent
    lobes."""
    return bool((masks and material.opacity < 1) or material.bump_map >= 0 or material.normal_map >= 0
                or material.back >= 0 or principled.needs_tangents(material))
