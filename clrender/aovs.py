"""Auxiliary outputs (AOVs): per-pixel images written beside the colour by the camera pass.

Two sources, one set of named images (`Renderer.render(aovs=...)`, `clrender render --aov`):

- Sample level (kernel feature AOVS, kernels/aovs.h): accumulated sample by sample beside the
  colour, so they are anti-aliased like it and bit-identical however the samples are split. They
  need the AOVS build of the kernel, which a render uses only when it asks for one of them.
    albedo    (H, W, 3) the albedo of each sample's first non-delta vertex (followed through
              smooth mirrors and glass, with their tints; media, emitters, the environment:
              kernels/aovs.h), averaged over the samples; in [0, 1] (OIDN's albedo)
    normal    (H, W, 3) the unit shading normal there, world space, facing where the path came
              from, averaged over the samples: shorter than 1 where samples disagree (edges,
              glass), 0 where no sample met a surface (OIDN's normal)
    emission  (H, W, 3) the part of the colour emitted there towards the camera: emitters and
              the environment seen directly or through mirrors and glass (lighting-free, so the
              denoiser leaves it out); the colour minus it is the light reflected or scattered
    variance  (H, W, 3) per channel, the unbiased estimate of the variance of the pixel's value
              (the mean of its n samples): m2 / (n (n - 1)) with m2 the sum of squared deviations
              of the samples from their mean, i.e. the squared standard error; n times it is
              the variance of one sample. inf where n < 2 (unknown).
- Pixel centre (kernels/aux_buffers.h, written with sample 0 by every render): the first surface
  through the pixel centre, deterministic and independent of the samples. Not averaged: an
  object id cannot be, and an averaged depth at a silhouette belongs to no surface (Cycles' Z and
  object-index passes are unfiltered too). The ink outlines (outlines.py) read this record.
    depth     (H, W) planar depth (along the camera axis) of that surface; inf where the ray escapes
    object_id (H, W) int32 its shape index; -1 where the ray escapes
"""
import numpy as np

SAMPLE_AOVS = ("albedo", "normal", "emission", "variance")
PIXEL_CENTRE_AOVS = ("depth", "object_id")
AOV_NAMES = SAMPLE_AOVS + PIXEL_CENTRE_AOVS


def parse_aovs(names, source="aovs"):
    """AOV names as a tuple in the order of AOV_NAMES, from an iterable of names or a
    comma-separated string; unknown names raise ValueError naming `source` (e.g. '--aov')."""
    if isinstance(names, str):
        names = [n.strip() for n in names.split(",") if n.strip()]
    names = list(names)
    unknown = [n for n in names if n not in AOV_NAMES]
    if unknown:
        raise ValueError(f"{source}: unknown AOV {unknown[0]!r}; valid: {', '.join(AOV_NAMES)}")
    return tuple(n for n in AOV_NAMES if n in names)


def needs_sample_aovs(names):
    """Whether rendering `names` needs the AOVS build of the kernel."""
    return any(n in SAMPLE_AOVS for n in names)


def pixel_centre_record(geometry, object_id, width, height):
    """The kernel's pixel-centre buffers as arrays: depth (H, W) (0 where the ray escapes),
    normal (H, W, 3) (0 there), object_id (H, W) (-1 there): RenderResult.aux."""
    geometry = geometry.reshape(height, width, 4)
    return {"depth": np.ascontiguousarray(geometry[..., 3]),
            "normal": np.ascontiguousarray(geometry[..., :3]),
            "object_id": object_id.reshape(height, width).copy()}


def sample_aov_images(aov_sums, colour_sums, width, height):
    """albedo, normal, emission and variance (see the module docstring) from the kernel's per-pixel AovSums
    (layout.AOV_SUMS) and colour sums (n, 4) (w: the samples of each pixel)."""
    counts = colour_sums[:, 3:4].astype(np.float64)
    n = np.maximum(counts, 1.0)

    def image(values):
        return values.reshape(height, width, 3).astype(np.float32)

    m2 = np.maximum(aov_sums["colour_m2"][:, :3].astype(np.float64), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        variance = np.where(counts >= 2, m2 / (n * (n - 1.0)), np.inf)
    return {"albedo": image(np.clip(aov_sums["albedo"][:, :3] / n, 0.0, 1.0)),
            "normal": image(aov_sums["normal"][:, :3] / n),
            "emission": image(aov_sums["emission"][:, :3] / n),
            "variance": image(variance)}


def aov_images(names, aux, sample_images):
    """The images of `names` from the pixel-centre record `aux` and the sample-level images."""
    missing = [n for n in names if n in SAMPLE_AOVS and n not in sample_images]
    if missing:
        raise ValueError(f"AOV {missing[0]!r} was not accumulated (start the Accumulation with sample_aovs)")
    hit = aux["object_id"] >= 0
    pixel_centre = {"depth": np.where(hit, aux["depth"], np.float32(np.inf)).astype(np.float32),
                    "object_id": aux["object_id"]}
    return {n: (pixel_centre[n] if n in PIXEL_CENTRE_AOVS else sample_images[n]) for n in names}
