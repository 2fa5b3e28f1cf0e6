"""Progressive rendering: short kernel launches that each add a few samples per pixel of a tile
(the whole image unless distributed.py splits it) to running per-pixel sums."""
import signal
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, replace

import numpy as np
import pyopencl as cl

from . import filters, guide, host_memory, layout, light_paths, limits, splatting
from . import sample_items as sample_items_module
from .aovs import aov_images, needs_sample_aovs, parse_aovs, pixel_centre_record, sample_aov_images
from .denoise import DenoiseSettings, check_denoiser, denoise_render
from .outlines import apply_outlines, composite
from .arrays import build_scene_arrays, moved_camera_medium
from .device import build_program, choose_device, device_errors
from .energy import fill_albedo_tables
from .errors import ArgumentError
from .features import scene_features
from .origins import errors_at_source
from .scene import Camera, as_scene


@dataclass
class RenderResult:
    image: np.ndarray            # linear float32 (H, W, 3), with the scene's outlines if enabled
    samples: int                 # samples per pixel actually taken
    seconds: float               # kernel time (launches and waits), excluding set-up
    discarded_samples: int       # non-finite samples dropped (counted as black)
    # First surface through each pixel centre: depth (H, W) float32 along the camera axis,
    # normal (H, W, 3) float32 unit shading normal facing the camera, object_id (H, W) int32
    # shape index; where the ray escapes: depth 0, normal 0, object_id -1.
    aux: dict = None
    outline_alpha: np.ndarray = None   # (H, W) ink coverage composited into image, or None
    aovs: dict = None                  # the AOVs asked for, name -> array (clrender/aovs.py)
    noisy_image: np.ndarray = None     # with denoise: the image before denoising (else None)
    denoise_seconds: float = 0.0       # time spent denoising

    @property
    def samples_per_second(self):
        h, w, _ = self.image.shape
        return self.samples * w * h / self.seconds if self.seconds > 0 else 0.0

    def __repr__(self):   # a summary: the arrays are in the fields
        h, w, _ = self.image.shape
        parts = [f"{w} x {h}", f"{self.samples} spp", f"{self.seconds:.3g} s",
                 f"{self.samples_per_second / 1e6:.3g} M samples/s"]
        if self.aovs:
            parts.append(f"aovs: {', '.join(self.aovs)}")
        if self.discarded_samples:
            parts.append(f"{self.discarded_samples} non-finite samples discarded")
        if self.noisy_image is not None:
            parts.append(f"denoised in {self.denoise_seconds:.3g} s")
        if self.outline_alpha is not None:
            parts.append("outlined")
        return f"RenderResult({', '.join(parts)})"


MAX_SPP = limits.MAX_SPP   # per-pixel sample counts are float32 in the accumulator
# A render's first launch covers at most this many pixels (a band of whole rows): before it, its
# time is unknown, and one sample of a 4K frame of a heavy scene could outlast a display GPU's
# watchdog (Windows: 2 s).
FIRST_LAUNCH_PIXELS = 1 << 18


@dataclass
class Accumulation:
    """The running per-pixel sums of one tile of the image after samples 0 .. samples - 1: what a
    render resumes from. Each pixel's samples are added one by one in index order onto these sums,
    so a tile rendered in chained chunks (distributed.py) holds exactly the bits of one render.
    Host arrays in the tile's row-major pixel order."""
    tile: tuple                  # (x, y, width, height): first column and row, size in pixels
    samples: int = 0             # samples per pixel summed so far: the next sample index
    sums: np.ndarray = None      # (width * height, 4) float32: radiance sums, w the samples counted
    discarded: int = 0           # non-finite samples dropped so far
    seconds: float = 0.0         # kernel time so far
    geometry: np.ndarray = None  # the aux buffers, written with sample 0 (None before):
    object_id: np.ndarray = None # (n, 4) float32 and (n,) int32, see RenderResult.aux
    aov_sums: np.ndarray = None  # (n,) layout.AOV_SUMS: the sample-level AOVs' sums, when they
                                 # are accumulated (the kernel's AOVS build), else None
    filtered: np.ndarray = None  # (n, 4) float32 when splatting (splatting.py): the sums of w L
                                 # (xyz) and of w (w) of the samples splatted to each pixel; the
                                 # image is their ratio. None before the first sample or without.
    light: np.ndarray = None     # (width * height, 3) int64 over the whole image: the fixed-point
                                 # sums of the light paths of this tile's samples (light_paths.py),
                                 # None where light paths do not apply
    light_paths: int = 0         # how many light paths those sums hold

    @classmethod
    def start(cls, tile, sample_aovs=False):
        """No samples yet; `sample_aovs`: accumulate the sample-level AOVs too."""
        n = tile[2] * tile[3]
        return cls(tuple(int(v) for v in tile), 0, np.zeros((n, 4), np.float32),
                   aov_sums=np.zeros(n, layout.AOV_SUMS) if sample_aovs else None)


def output_request(aovs=(), denoise=False, denoise_prefilter=False, denoise_keep_emission=False):
    """The AOV names a render accumulates (those asked for, and the denoiser's guides) and its
    DenoiseSettings (None without denoising); raises before any rendering if the denoiser is
    missing."""
    names = parse_aovs(aovs)
    denoising = DenoiseSettings(denoise_prefilter, denoise_keep_emission) if denoise else None
    if denoising:
        check_denoiser()
        names = parse_aovs(names + denoising.aovs())
    return names, denoising


def image_result(scene, state, aovs=(), denoising=None):
    """The RenderResult of a whole-image Accumulation: sums normalised per pixel by their sample
    count, or splatted sums by their weights (so an interrupted render is exact for what was
    done), the AOVs named in `aovs`
    (their sums must be in `state` for the sample-level ones), denoised with the
    DenoiseSettings `denoising` unless None, with the scene's outlines."""
    width, height = scene.camera.resolution
    if tuple(state.tile) != (0, 0, width, height):
        raise ArgumentError("state.tile", f"expected the whole {width}x{height} image, got tile {state.tile}")
    sums = state.sums if state.filtered is None else state.filtered
    with np.errstate(invalid="ignore", divide="ignore"):
        image = np.where(sums[:, 3:4] > 0, sums[:, :3] / sums[:, 3:4], 0.0)
    image = image.reshape(height, width, 3).astype(np.float32)
    if state.light is not None:
        image += light_paths.image(state.light, state.light_paths, scene.camera.filter, width, height)
    geometry, object_id = state.geometry, state.object_id
    if geometry is None:   # interrupted before sample 0: as if every centre ray escaped
        geometry, object_id = np.zeros((width * height, 4), np.float32), np.full(width * height, -1, np.int32)
    aux = pixel_centre_record(geometry, object_id, width, height)
    sample_images = {}
    if state.aov_sums is not None:
        sample_images = sample_aov_images(state.aov_sums, state.sums, width, height)
    images = aov_images(aovs, aux, sample_images)
    noisy, denoise_seconds = None, 0.0
    if denoising:
        start = time.perf_counter()
        noisy, image = image, denoise_render(image, images, denoising)
        denoise_seconds = time.perf_counter() - start
    # Ink goes on after denoising: it is exact, and the denoiser would blur it.
    image, alpha = apply_outlines(image, aux, scene.outlines)
    if noisy is not None and alpha is not None:
        noisy = composite(noisy, alpha, scene.outlines.color)
    return RenderResult(image, state.samples, state.seconds, state.discarded,
                        aux=aux, outline_alpha=alpha, aovs=images, noisy_image=noisy,
                        denoise_seconds=denoise_seconds)


@contextmanager
def progress_bar(total, pixels):
    """A render's `progress` as a tqdm bar on stderr, as the command line shows it: samples per
    pixel done of `total` (None: unknown, a time-limited render) and the sample rate."""
    from tqdm import tqdm

    bar = tqdm(total=total, unit="spp", file=sys.stderr, dynamic_ncols=True)

    def progress(done, end, seconds):
        bar.update(done - bar.n)
        bar.set_postfix_str(f"{done * pixels / max(seconds, 1e-9) / 1e6:.2f} M samples/s")

    try:
        yield progress
    finally:
        bar.close()


@contextmanager
def progress_callback(progress, total, pixels):
    """The callback `progress(samples_done, total, seconds)` for a render's `progress` argument:
    None or False none, True a progress_bar, a callable itself."""
    if progress is None or progress is False:
        yield None
    elif progress is True:
        with progress_bar(total, pixels) as bar:
            yield bar
    elif callable(progress):
        yield progress
    else:
        raise ArgumentError("progress", f"must be True, False, None or a callable, got {limits.show(progress)}")


def sampler_code(scene, override=None):
    """The RenderParams.sampling.x of the sampler named by `override`, else the scene's
    render.sampler (ArgumentError naming `sampler` if unknown)."""
    name = override if override is not None else scene.render.sampler
    if not isinstance(name, str) or name not in layout.SAMPLERS:
        raise ArgumentError("sampler", f"unknown sampler {name!r}; valid: {', '.join(layout.SAMPLERS)}")
    return layout.SAMPLERS[name]


def render_params(scene, arrays, first_sample, samples, max_depth, rr_depth, seed, spectral_mis=True,
                  step=None, raymarch_multiple_scattering=None, tile=None, sampler=None, splat=None,
                  light_path_every=0):
    """The RenderParams struct of one launch. `step`, `raymarch_multiple_scattering` (ray
    marching of grid media) and `sampler` default to the scene's render settings; `tile` (x, y,
    width, height), the pixels traced, to the whole image; `splat` the tile their samples are
    splatted to (splatting.py; None: no splatting)."""
    camera = scene.camera
    width, height = camera.resolution
    forward, right, up = camera.basis()
    p = np.zeros(1, layout.RENDER_PARAMS)
    p["camera"]["origin"][0, :3] = camera.position * arrays.length_scale
    p["camera"]["forward"][0, :3] = forward
    p["camera"]["right"][0, :3] = right
    p["camera"]["up"][0, :3] = up
    p["camera"]["lens"][0, :2] = (camera.aperture_radius * arrays.length_scale, camera.focus_distance * arrays.length_scale)
    p["frame"] = (width, height, first_sample, samples)
    # The kernel reads the seed as uint (0..2^32-1): store its bits in the int4's slot.
    p["config"] = (max_depth, rr_depth, np.array(seed, np.uint32).view(np.int32), len(arrays.emitters))
    p["environment"] = (arrays.env_index, *arrays.env_size, hidden_from_camera(scene.render))
    p["env_lookup"] = (arrays.env_lookup, 0, 0, 0)
    p["env_to_map"][0, :, :3] = arrays.env_to_map
    p["media"] = (arrays.camera_medium, int(spectral_mis), 0, 0)
    settings = scene.render
    step = settings.step if step is None else step
    multiple = (settings.raymarch_multiple_scattering if raymarch_multiple_scattering is None
                else raymarch_multiple_scattering)
    p["volume"] = (step, float(bool(multiple)), 0, 0)
    p["scene_sphere"] = arrays.scene_sphere
    p["lights"] = (arrays.first_light, 0, 0, 0)
    p["tile"] = (0, 0, width, height) if tile is None else tile
    p["splat"] = (0, 0, 0, 0) if splat is None else splat
    p["splat_reach"] = (splatting.reach(camera.filter) if splat is not None else 0, 0, 0, 0)
    p["sampling"] = (sampler_code(scene, sampler), *direct_samples(scene.render), 0)
    p["filter"] = filters.filter_record(camera.filter)
    p["light_paths"] = (int(light_path_every > 0), light_path_every, 0, 0)
    p["guide_grid"] = arrays.guide_grid
    p["guide_cells"] = arrays.guide_cells
    p["guide_cone"] = arrays.guide_cone
    return p


def hidden_from_camera(settings):
    """RenderParams.environment.w: the layout.HIDDEN_FROM_CAMERA bits of the render settings."""
    hidden = layout.HIDDEN_FROM_CAMERA
    return ((hidden["environment"] if settings.hide_environment or settings.hide_emitters else 0)
            | (hidden["emitting_shapes"] if settings.hide_emitters else 0))


def direct_samples(settings):
    """RenderParams.sampling.yz: the direct integrator's light and BSDF samples, (0, 0) for path tracing."""
    if settings.integrator != "direct":
        return 0, 0
    return settings.emitter_samples, settings.bsdf_samples


def march_notes(scene):
    """What ray marching cannot resolve in `scene`: grid media so dense that the refinement of
    steps by optical depth stops (kernels/media/raymarch.h), as sentences for the user."""
    limit = layout.MARCH_STEP_OPTICAL_DEPTH * layout.MARCH_MAX_STEPS_PER_VOXEL
    notes = []
    for medium in scene.media:
        if medium.grid is None:
            continue
        depth = float(medium.grid.density.max() * np.max(medium.sigma_t)) * medium.grid.longest_voxel_step()
        if depth > limit:
            notes.append(f"ray marching: medium {medium.name!r} holds up to {depth:.3g} optical depths per voxel; "
                         f"steps stop shrinking at 1/{layout.MARCH_MAX_STEPS_PER_VOXEL:g} voxel (x step), so steps "
                         f"through its densest parts exceed the usual {layout.MARCH_STEP_OPTICAL_DEPTH:g} x step "
                         "optical depth (more bias at its edges; use null scattering for exact results)")
    return notes


class RenderInterrupted(KeyboardInterrupt):
    """Ctrl-C (or SIGTERM/SIGHUP, see errors.Interrupted) during a render; `result` holds what
    was completed so far: the RenderResult of `render`, the Accumulation of
    `Renderer.accumulate`; `signal` the signal number."""

    def __init__(self, result, signum=signal.SIGINT):
        super().__init__("render interrupted")
        self.result = result
        self.signal = signum


# Work-group size of the packet kernel (LANES 8) when the caller gives none: 4 x 4 work-items,
# 128 pixels.
PACKET_LOCAL_SIZE = (4, 4)
# The megakernel's on CPU devices. Left to the implementation, the size follows the launch's
# shape, which the launches' timing adapts, and PoCL compiles the kernel for each size it picks
# (seconds for the megakernel; cached on disk): a render of the SSS bunny took 28-36 s at 16 spp
# where it takes 2.5-3 s with one size, a compile being taken for slowness and shrinking the
# launches to single rows (docs/performance.md).
CPU_LOCAL_SIZE = (8, 1)


class Renderer:
    """A scene uploaded to one device with its specialised kernel, ready to render many times."""

    @device_errors()
    def __init__(self, scene, device=None, local_size=None, pass_seconds=0.25, spectral_mis=True,
                 volume_method=None, step=None, raymarch_multiple_scattering=None, context=None, sampler=None,
                 packets=None, sample_items=None):
        """`scene`: a Scene, a scene dict or a file path. `device`: an OpenCL device or a choice
        for `choose_device` (default: the device of `context` if given). `volume_method`
        ("null" or "raymarch"), `step` (ray marching's longest step in voxels, >=
        limits.MIN_MARCH_STEP) and `raymarch_multiple_scattering` override the scene's render
        settings for grid media; `sampler` ("sobol" or "independent") the scene's render.sampler.
        `context`: an existing context of `device` to share, so renderers of many scenes reuse
        its built programs. `packets`: trace camera paths 8 per work-item where the packet
        integrator covers the scene (features.packets_cover); default: on CPU devices, whose
        vector lanes then carry them (the image is the same to float rounding), unless
        `sample_items`. `sample_items`: a render pass takes one work-item per pixel and sample
        (clrender/sample_items.py; the same image bit for bit); default: on GPUs (not with packets)."""
        self.scene = scene = as_scene(scene)
        step = None if step is None else limits.setting("step", step)
        limits.number(pass_seconds, "pass_seconds", low=0.0, low_open=True)
        if context is not None and not isinstance(context, cl.Context):
            raise ArgumentError("context", f"must be a pyopencl Context, got {type(context).__name__}")
        if device is None and context is not None:
            device = context.devices[0]
        self.device = device if isinstance(device, cl.Device) else choose_device(device)
        self.context = context if context is not None else cl.Context([self.device])
        self.queue = cl.CommandQueue(self.context)
        if packets is None:
            packets = bool(self.device.type & cl.device_type.CPU) and not sample_items
        self.features = scene_features(scene, volume_method, packets=packets)
        if sample_items and self.features["LANES"] > 1:
            raise ArgumentError("sample_items", "the packet integrator takes a pixel's samples in turn: "
                                                "ask for sample items without packets")
        # Limits of the chosen method that the image may show, for the user (the CLI prints them).
        self.notes = march_notes(scene) if self.features["GRID_MEDIA"] == layout.VOLUME_METHODS["raymarch"] else []
        self.step = step
        self.raymarch_multiple_scattering = raymarch_multiple_scattering
        sampler_code(scene, sampler)   # checked before anything is built
        self.sampler = sampler
        with errors_at_source(scene):
            limits.check_image_fits(scene.camera.resolution, self.device)
            self.arrays = build_scene_arrays(scene)
            limits.check_arrays_fit({name: getattr(self.arrays, name) for name in self.ARRAYS}, self.device)
        program = build_program(self.context, self.features)
        self.kernel = cl.Kernel(program, "render_pass")
        self._aov_kernel = None   # the AOVS build, made when a render first asks for it
        # PoCL's own choice for the packet kernel (groups of up to 4096 work-items) crashed its
        # AOV build at 256 x 256 (a segmentation fault); every size from 1 x 1 to 16 x 4 runs it
        # equally fast (docs/performance.md), so packets get 4 x 4 unless told otherwise.
        if local_size is None and self.features["LANES"] > 1:
            local_size = PACKET_LOCAL_SIZE
        elif local_size is None and self.device.type & cl.device_type.CPU:
            local_size = CPU_LOCAL_SIZE
        self.local_size = local_size
        self.pass_seconds = pass_seconds
        # Camera samples per light path where light paths take the caustics (light_paths.py), else 0.
        self.light_path_every = light_paths.EVERY if light_paths.applies(scene, self.features) else 0
        self._light_kernel = None
        self.spectral_mis = spectral_mis
        fill_albedo_tables(self.queue, self.arrays)
        self._buffers = [self._upload(getattr(self.arrays, name)) for name in self.ARRAYS]
        if guide.applies(scene, self.features):
            self._build_guide()
        self._gather = splatting.Gather(self.context, scene.camera.filter, packets) if splatting.splats(scene) else None
        if sample_items is None:
            sample_items = sample_items_module.wanted(self.device, self.features)
        self._sample_sums = sample_items_module.SampleSums(self.context, packets) if sample_items else None
        self._aov_sample_sums = None   # the one that adds the sample-level AOVs too, when asked for
        # The render pass's records argument when it does not splat.
        self._no_records = cl.Buffer(self.context, cl.mem_flags.READ_WRITE, 4)

    # The scene arrays passed to the kernel, in argument order after the RenderParams.
    ARRAYS = ("nodes", "blocks", "spheres", "shading", "info", "materials", "media", "emitters",
              "emitter_cdf", "env_texels", "env_cdf", "specular_albedo", "grid_data", "majorant_data",
              "uvs", "textures", "texels", "guide")

    def update_array(self, name, array):
        """Replace one of the scene arrays on the device (same dtype and meaning), e.g. an
        edited density grid (`grid_data`, with its `majorant_data`) between renders."""
        if name not in self.ARRAYS:
            raise ArgumentError("name", f"unknown array {name!r}; valid: {', '.join(self.ARRAYS)}")
        index = self.ARRAYS.index(name)
        # A copy: the caller's array may change later, and a CPU device reads this one in place.
        array = np.array(array, dtype=getattr(self.arrays, name).dtype)
        setattr(self.arrays, name, array)
        self._buffers[index] = self._upload(array)

    def set_camera(self, camera):
        """Render from `camera` (a scene.Camera of the same resolution) from now on. The scene
        stays on the device: only the RenderParams of later launches change, and in a scene with
        media the medium around the camera is found again. The length scale stays the one chosen
        for the scene (arrays.device_length_scale), a float32 safeguard, not a part of the image."""
        if not isinstance(camera, Camera):
            raise ArgumentError("camera", f"must be a clrender.scene.Camera, got {type(camera).__name__}")
        if tuple(camera.resolution) != tuple(self.scene.camera.resolution):
            raise ArgumentError("camera.resolution", f"must stay {self.scene.camera.resolution} (the buffers' size), "
                                                     f"got {camera.resolution}")
        with np.errstate(invalid="ignore", divide="ignore"):
            basis = np.concatenate(camera.basis())
        if not np.all(np.isfinite(basis)) or not np.all(np.isfinite(camera.position)):
            raise ArgumentError("camera", "its position, look_at and up must be finite and span a view")
        scene = replace(self.scene, camera=camera)
        if scene.media:
            self.arrays.camera_medium = moved_camera_medium(scene, self.arrays.length_scale)
        self.scene = scene

    def _upload(self, array):
        """A read-only device buffer of `array`. On a CPU whose memory is the host's (PoCL,
        Intel's runtime; not Oclgrind, a simulator with memory of its own) the kernels read the
        array where it is (host_memory.py; the buffer keeps it alive), no copy (the staircase's
        110 MB took 0.14 s to copy, and a large mesh's arrays were in memory twice); elsewhere
        a copy."""
        data = array if array.size else np.zeros(1, array.dtype)
        if self.device.type & cl.device_type.CPU and self.device.host_unified_memory:
            flags = cl.mem_flags.USE_HOST_PTR
            data = host_memory.aligned(data)
        else:
            flags = cl.mem_flags.COPY_HOST_PTR
            data = np.ascontiguousarray(data)
        return cl.Buffer(self.context, cl.mem_flags.READ_ONLY | flags, hostbuf=data)

    @device_errors()
    def render(self, spp=None, seed=None, max_depth=None, rr_depth=None, progress=None,
               samples_per_pass=None, time_limit=None, aovs=None, denoise=False, denoise_prefilter=False,
               denoise_keep_emission=False):
        """Render and return a RenderResult. `progress(samples_done, spp, seconds)` is called
        after every launch (samples_done a fraction after a band of rows); `progress=True` shows
        a bar on stderr instead, as the command line does. Samples per launch
        adapt to `pass_seconds` (down to bands of rows of one sample, for GPU watchdogs) unless
        fixed by `samples_per_pass` (whole frames); the image does not depend on the split. With
        `time_limit` (seconds of kernel time) rendering stops after the launch that reaches it,
        or at `spp` if given.
        `aovs`: names of auxiliary images to return in result.aovs (clrender/aovs.py; None:
        the scene's render.aovs); they leave the colour bit for bit as it is. `denoise`: the image is denoised by Open Image
        Denoise guided by the albedo and normal AOVs (returned too), result.noisy_image keeps the
        raw one; `denoise_prefilter` denoises the guides first, `denoise_keep_emission` leaves the
        emission AOV out of the filter and adds it back (clrender/denoise.py, docs/denoising.md).
        Ctrl-C (SIGTERM, SIGHUP in the CLI) raises RenderInterrupted with the RenderResult of the
        launches completed."""
        limits.check_settings(spp=spp, seed=seed, max_depth=max_depth, rr_depth=rr_depth,
                              samples_per_pass=samples_per_pass, time_limit=time_limit)
        self._check_depths(max_depth, rr_depth)
        names, denoising = output_request(self.scene.render.aovs if aovs is None else aovs, denoise,
                                          denoise_prefilter, denoise_keep_emission)
        if spp is None and time_limit is None:
            spp = self.scene.render.spp
        width, height = self.scene.camera.resolution
        empty = Accumulation.start((0, 0, width, height), needs_sample_aovs(names))
        try:
            with progress_callback(progress, spp, width * height) as callback:   # spp None: until the time limit
                state = self.accumulate(empty, MAX_SPP if spp is None else spp, seed, max_depth, rr_depth,
                                        callback, samples_per_pass, time_limit)
        except RenderInterrupted as interrupted:
            raise RenderInterrupted(image_result(self.scene, interrupted.result, names, denoising),
                                    interrupted.signal) from None
        return image_result(self.scene, state, names, denoising)

    def accumulate(self, state, samples, seed=None, max_depth=None, rr_depth=None, progress=None,
                   samples_per_pass=None, time_limit=None):
        """Add samples state.samples ... state.samples + samples - 1 to the sums of the tile of
        `state` and return the new Accumulation; the arguments are those of `render`, with
        `progress(samples_done, samples_end, seconds)`. Ctrl-C raises RenderInterrupted with the
        Accumulation of the launches completed; any other exception raised by `progress` stops
        the render between two launches and propagates (the viewer cancels passes so). The
        sample-level AOVs are accumulated too when `state` holds their sums."""
        self._check_accumulation(state, samples)
        limits.check_settings(seed=seed, max_depth=max_depth, rr_depth=rr_depth,
                              samples_per_pass=samples_per_pass, time_limit=time_limit)
        self._check_depths(max_depth, rr_depth)
        settings = self.scene.render
        seed = settings.seed if seed is None else seed
        max_depth = settings.max_depth if max_depth is None else max_depth
        rr_depth = settings.rr_depth if rr_depth is None else rr_depth
        # The pixels traced: the tile, grown by the filter's reach when splatting; the per-pixel
        # buffers below are theirs, the tile's part of them is the Accumulation's.
        width, height = self.scene.camera.resolution
        traced = (splatting.traced_tile(state.tile, self._gather.reach, width, height) if self._gather
                  else state.tile)
        _, _, tile_width, tile_height = traced
        n = tile_width * tile_height
        mf = cl.mem_flags
        sums = splatting.embed(np.asarray(state.sums, dtype=np.float32), state.tile, traced)
        accum_buffer = cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=sums)
        discarded = np.zeros(1, np.int32)
        discarded_buffer = cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=discarded)
        # Written by the launch holding sample 0.
        aux_buffers = (cl.Buffer(self.context, mf.WRITE_ONLY, n * 16),
                       cl.Buffer(self.context, mf.WRITE_ONLY, n * 4))
        # Read by the AOVS build only; the colour-only build gets a placeholder.
        aov_sums = (splatting.embed(np.asarray(state.aov_sums, dtype=layout.AOV_SUMS), state.tile, traced)
                    if state.aov_sums is not None else np.zeros(1, layout.AOV_SUMS))
        aov_buffer = cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=aov_sums)
        splat = self._splat_buffers(state, traced, samples)
        items = self._sample_sums is not None
        # With sample items the sample-level AOVs are records too, summed with the colour's.
        records, aov_records, most = self._pass_records(splat, items, traced, samples, state.aov_sums is not None)
        sums_of_samples = self._sums_of_samples(aov_records) if items else None
        kernel, lanes = self._kernel(state.aov_sums is not None)
        params_buffer = cl.Buffer(self.context, mf.READ_ONLY, layout.RENDER_PARAMS.itemsize)

        end = state.samples + samples
        done, per_pass, seconds = state.samples, samples_per_pass or 1, 0.0
        light = _LightSums(state.light, state.light_paths) if self.light_path_every else None
        rows = tile_height if samples_per_pass else self._first_launch_rows(tile_width, tile_height)
        try:
            while done < end and (time_limit is None or seconds < time_limit):
                count = min(per_pass, end - done, most)
                params = render_params(self.scene, self.arrays, done, count, max_depth, rr_depth,
                                       seed, self.spectral_mis, self.step, self.raymarch_multiple_scattering,
                                       traced, self.sampler, state.tile if splat else None,
                                       self.light_path_every)
                cl.enqueue_copy(self.queue, params_buffer, params)
                # The tile's rows in bands of `rows` (a multiple of the work-group height but for
                # the last, whose excess rows the kernel's guard skips), each band a launch told
                # its first row: every pixel gets these samples once, in index order. With sample
                # items a pass of several samples is launched over them too (a pass of one runs
                # as a plain pass: the kernel tells them apart by the launch's third dimension),
                # and its records are summed once all its rows are traced.
                items_of_pass = count if items else 1
                for first_row in range(0, tile_height, rows):
                    band = min(rows, tile_height - first_row)
                    start = time.perf_counter()
                    global_size, local_size = self._launch_size(tile_width, band, lanes, items_of_pass)
                    aovs_argument = aov_records if items_of_pass > 1 and aov_records is not None else aov_buffer
                    kernel(self.queue, global_size, local_size, params_buffer, *self._buffers, accum_buffer,
                           discarded_buffer, *aux_buffers, aovs_argument, records, np.int32(first_row))
                    if first_row + band >= tile_height:
                        if items_of_pass > 1:
                            sums_of_samples(self.queue, traced, params_buffer, records, accum_buffer,
                                            *(() if aov_records is None else (aov_records, aov_buffer)))
                        if splat:
                            self._gather(self.queue, state.tile, params_buffer, splat.records, splat.filtered)
                    self.queue.finish()
                    elapsed = time.perf_counter() - start
                    seconds += elapsed
                    if progress is not None and first_row + band < tile_height:   # a fraction of a sample
                        progress(done + count * (first_row + band) / tile_height, end, state.seconds + seconds)
                if light is not None:
                    start = time.perf_counter()
                    self._trace_light_paths(light, state.tile, done, count, max_depth, rr_depth, seed)
                    seconds += time.perf_counter() - start
                done += count
                if splat:
                    splat.samples = done
                if samples_per_pass is None:
                    per_pass, rows = self._next_launch(count, band, tile_height, elapsed)
                if progress is not None:
                    progress(done, end, state.seconds + seconds)
        except KeyboardInterrupt as interrupt:
            self.queue.finish()
            raise RenderInterrupted(self._download(state, traced, accum_buffer, discarded_buffer, aux_buffers,
                                                   aov_buffer, splat, seconds, light=light),
                                    getattr(interrupt, "signal", signal.SIGINT)) from None
        return self._download(state, traced, accum_buffer, discarded_buffer, aux_buffers, aov_buffer, splat, seconds,
                              done, light)

    def _build_guide(self):
        """The caustic guide (guide.py): its photons traced on the device
        (kernels/guide_photons.cl), their records binned on the host into the `guide` array and
        the RenderParams fields that switch it on; nothing where no photon lands."""
        program = build_program(self.context, {**self.features, "LANES": 1}, entry="guide_photons.cl")
        mf = cl.mem_flags
        params = render_params(self.scene, self.arrays, 0, 0, 1, 1, 0, self.spectral_mis)
        params_buffer = cl.Buffer(self.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=params)
        records = cl.Buffer(self.context, mf.READ_WRITE, guide.PHOTONS * guide.RECORD_FLOATS * 4)   # one each at most
        written = np.zeros(1, np.int32)
        written_buffer = cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=written)
        target = guide.specular_sphere(self.scene, self.arrays.length_scale)
        cl.Kernel(program, "guide_photons")(self.queue, (guide.PHOTONS,), None, params_buffer, *self._buffers,
                                            target, np.uint32(guide.SEED), np.int32(guide.PHOTONS), records,
                                            written_buffer, np.int32(guide.PHOTONS))
        cl.enqueue_copy(self.queue, written, written_buffer)
        out = np.empty((min(int(written[0]), guide.PHOTONS), guide.RECORD_FLOATS), np.float32)
        if len(out):
            cl.enqueue_copy(self.queue, out, records)
        built = guide.build(out)
        if built is None:
            return
        lobes, self.arrays.guide_grid, self.arrays.guide_cells, self.arrays.guide_cone = built
        self.update_array("guide", lobes)

    def _trace_light_paths(self, light, tile, first, count, max_depth, rr_depth, seed):
        """Add the light paths of samples first .. first + count - 1 of the tile's pixels to
        `light` (_LightSums): their kernel (kernels/light_paths.cl, built at first use) writes
        their records, which are splatted and summed on the host (light_paths.py)."""
        paths = light_paths.paths_of(tile, first, count)
        if paths == 0:
            return
        if self._light_kernel is None:
            program = build_program(self.context, {**self.features, "LANES": 1}, entry="light_paths.cl")
            self._light_kernel = cl.Kernel(program, "light_paths")
        mf = cl.mem_flags
        params = render_params(self.scene, self.arrays, first, count, max_depth, rr_depth, seed, self.spectral_mis,
                               tile=tile, light_path_every=self.light_path_every)
        params_buffer = cl.Buffer(self.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=params)
        capacity = max(1024, paths)
        while True:   # until the records fit (the same light paths each time: keyed by pixel and sample)
            records = cl.Buffer(self.context, mf.READ_WRITE, capacity * light_paths.RECORD_FLOATS * 4)
            written = np.zeros(1, np.int32)
            written_buffer = cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=written)
            global_size, local_size = self._launch_size(tile[2], tile[3])
            self._light_kernel(self.queue, global_size, local_size, params_buffer, *self._buffers, records,
                               written_buffer, np.int32(capacity))
            cl.enqueue_copy(self.queue, written, written_buffer)
            if written[0] <= capacity:
                break
            capacity = int(written[0])
        out = np.empty((int(written[0]), light_paths.RECORD_FLOATS), np.float32)
        if len(out):
            cl.enqueue_copy(self.queue, out, records)
        width, height = self.scene.camera.resolution
        light.add(light_paths.splat(out, self.scene.camera.filter, width, height), paths)

    def _splat_buffers(self, state, traced, samples):
        """_SplatBuffers for accumulating `samples` onto `state` over the pixels `traced`, or None
        without splatting."""
        if self._gather is None:
            return None
        n = state.tile[2] * state.tile[3]
        if state.filtered is None and state.samples > 0:
            raise ArgumentError("state", "holds samples without their splatted sums (filtered): it was not "
                                         "accumulated by splatting")
        filtered = state.filtered if state.filtered is not None else np.zeros((n, 4), np.float32)
        mf = cl.mem_flags
        most = min(samples, splatting.samples_per_pass_limit(traced, splatting.record_bytes(self._gather.reach)))
        records = most * traced[2] * traced[3]
        return _SplatBuffers(cl.Buffer(self.context, mf.READ_WRITE, records * splatting.record_bytes(self._gather.reach)),
                             cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR,
                                       hostbuf=np.ascontiguousarray(filtered, dtype=np.float32)),
                             state.samples, most)

    def _pass_records(self, splat, items, traced, samples, sample_aovs):
        """(records, AOV records, most samples per pass) of an accumulation of `samples` over the
        pixels `traced`: the splatting records when the film splats (`splat`), else with sample
        items (`items`) a buffer of their radiance, else a placeholder and no limit; with sample
        items accumulating the sample-level AOVs (`sample_aovs`), a buffer of the samples' AOV
        records (layout.AOV_SUMS), else None. Within the records' budget; where it allows one
        sample per pass, the passes are plain ones, which write no sample records."""
        if not items:
            return (splat.records, None, splat.samples_per_pass) if splat else (self._no_records, None, MAX_SPP)
        pixels = traced[2] * traced[3]
        most = (splat.samples_per_pass if splat
                else min(samples, splatting.samples_per_pass_limit(traced, splatting.record_bytes(0))))
        if sample_aovs:
            most = min(most, splatting.samples_per_pass_limit(traced, layout.AOV_SUMS.itemsize))
        records = (splat.records if splat else self._no_records if most == 1
                   else cl.Buffer(self.context, cl.mem_flags.READ_WRITE, most * pixels * splatting.record_bytes(0)))
        aov_records = (cl.Buffer(self.context, cl.mem_flags.READ_WRITE, most * pixels * layout.AOV_SUMS.itemsize)
                       if sample_aovs and most > 1 else None)
        return records, aov_records, most

    def _sums_of_samples(self, aov_records):
        """The sum_samples kernel for a pass's records: the one adding AOV records too where there
        are some (built when first asked for)."""
        if aov_records is None:
            return self._sample_sums
        if self._aov_sample_sums is None:
            self._aov_sample_sums = sample_items_module.SampleSums(self.context, sample_aovs=True)
        return self._aov_sample_sums

    def _check_depths(self, max_depth, rr_depth):
        """Path depths given for a scene of the direct integrator, which has none (ArgumentError)."""
        for name, value in (("max_depth", max_depth), ("rr_depth", rr_depth)):
            if value is not None and self.scene.render.integrator == "direct":
                raise ArgumentError(name, "does not apply to the direct integrator (render.integrator 'direct')")

    def _check_accumulation(self, state, samples):
        """`state` is an Accumulation of a tile inside the image, and `samples` more keep its
        per-pixel counts within MAX_SPP (ArgumentError)."""
        if not isinstance(state, Accumulation):
            raise ArgumentError("state", f"must be an Accumulation, got {type(state).__name__}")
        width, height = self.scene.camera.resolution
        x, y, tile_width, tile_height = state.tile
        if not (0 <= x and 0 <= y and tile_width >= 1 and tile_height >= 1
                and x + tile_width <= width and y + tile_height <= height):
            raise ArgumentError("state.tile", f"{state.tile} is not a tile of the {width}x{height} image")
        n = tile_width * tile_height
        if (np.shape(state.sums) != (n, 4) or (state.aov_sums is not None and np.shape(state.aov_sums) != (n,))
                or (state.filtered is not None and np.shape(state.filtered) != (n, 4))):
            raise ArgumentError("state", f"its sums do not have the {n} pixels of its tile")
        if state.light is not None and np.shape(state.light) != (width * height, 3):
            raise ArgumentError("state.light", f"must be the {width * height} pixels of the image's light-path sums")
        limits.number(state.samples, "state.samples", low=0, high=MAX_SPP, integer=True)
        limits.setting("spp", samples, "samples")
        if state.samples + samples > MAX_SPP:
            raise ArgumentError("samples", f"{state.samples} + {samples} samples per pixel, more than "
                                           f"the limit of {MAX_SPP}")

    def _kernel(self, sample_aovs):
        """(kernel, camera paths per work-item): the colour-only kernel, or the one that also
        accumulates the sample-level AOVs."""
        if not sample_aovs:
            return self.kernel, self.features["LANES"]
        if self._aov_kernel is None:
            program = build_program(self.context, {**self.features, "AOVS": 1})
            self._aov_kernel = cl.Kernel(program, "render_pass")
        return self._aov_kernel, self.features["LANES"]

    def _launch_size(self, width, height, lanes=1, items=1):
        """(global size, local size) of a launch over a tile of width x height pixels, `lanes`
        adjacent pixels of a row per work-item, and `items` samples over a third dimension when
        more than one (sample items)."""
        width = -(-width // lanes)
        if self.local_size is None:
            size, local = (width, height), None
        else:
            lx, ly = self.local_size
            size, local = (-(-width // lx) * lx, -(-height // ly) * ly), self.local_size
        if items > 1:
            return size + (items,), None if local is None else tuple(local) + (1,)
        return size, local

    def _band_rows(self, rows, height):
        """`rows` rounded down to a multiple of the work-group height (at least one), at most
        the tile's `height`."""
        step = 1 if self.local_size is None else self.local_size[1]
        return min(height, max(step, rows // step * step))

    def _first_launch_rows(self, width, height):
        """The first launch, whose time is not known yet, covers at most FIRST_LAUNCH_PIXELS."""
        return self._band_rows(FIRST_LAUNCH_PIXELS // width, height)

    def _next_launch(self, count, rows, height, elapsed):
        """(samples, rows) of the next launches, from the last one (`count` samples over `rows`
        rows in `elapsed` s): work (samples x rows) of about pass_seconds, at most 4x the last
        (2x when it took no measurable time); the whole tile's rows once that is at least one
        sample of all of them, else bands of one sample, so that no launch runs long enough for a
        GPU watchdog however large the frame (portability.md)."""
        work = count * rows
        target = 2 * work if elapsed <= 0 else min(int(work * self.pass_seconds / elapsed), 4 * work)
        if target >= height:
            return target // height, height
        return 1, self._band_rows(target, height)

    def _download(self, state, traced, accum_buffer, discarded_buffer, aux_buffers, aov_buffer, splat, seconds,
                  samples=None, light=None):
        """The Accumulation after the launches completed on `state`'s buffers (of the pixels
        `traced`), which hold `samples` per pixel (None: count them, after Ctrl-C)."""
        n = traced[2] * traced[3]
        sums = np.empty((n, 4), np.float32)
        discarded = np.empty(1, np.int32)
        cl.enqueue_copy(self.queue, sums, accum_buffer)
        cl.enqueue_copy(self.queue, discarded, discarded_buffer)
        sums = splatting.crop(sums, traced, state.tile)
        # Every launch adds its samples to every pixel of the tile and w counts them, so the
        # sums say how many were taken even when Ctrl-C came between a launch and its count.
        # Splatted sums hold the passes gathered: the image is their ratio, whatever the count.
        if samples is None:
            samples = splat.samples if splat else int(sums[:, 3].min())
        geometry, object_id = state.geometry, state.object_id
        if state.samples == 0 and samples > 0:
            geometry = np.empty((n, 4), np.float32)
            object_id = np.empty(n, np.int32)
            cl.enqueue_copy(self.queue, geometry, aux_buffers[0])
            cl.enqueue_copy(self.queue, object_id, aux_buffers[1])
            geometry, object_id = splatting.crop(geometry, traced, state.tile), splatting.crop(object_id, traced, state.tile)
            geometry[:, 3] /= self.arrays.length_scale      # depth in scene units
        aov_sums = None
        if state.aov_sums is not None:
            aov_sums = np.empty(n, layout.AOV_SUMS)
            cl.enqueue_copy(self.queue, aov_sums, aov_buffer)
            aov_sums = splatting.crop(aov_sums, traced, state.tile)
        filtered = state.filtered
        if splat:
            filtered = np.empty((len(sums), 4), np.float32)
            cl.enqueue_copy(self.queue, filtered, splat.filtered)
        return Accumulation(state.tile, samples, sums, state.discarded + int(discarded[0]),
                            state.seconds + seconds, geometry, object_id, aov_sums, filtered,
                            *((light.sums, light.paths) if light is not None else (state.light, state.light_paths)))


class _LightSums:
    """The light paths' fixed-point sums over the whole image (light_paths.py) while a tile
    accumulates, and how many light paths they hold."""

    def __init__(self, sums, paths):
        self.sums, self.paths = (None if sums is None else sums.copy()), paths

    def add(self, sums, paths):
        self.sums = sums if self.sums is None else self.sums + sums
        self.paths += paths


@dataclass
class _SplatBuffers:
    """One accumulation's splatting buffers: the records of a pass, the tile's splatted sums, how
    many samples per pixel those hold, and the most a pass may take (the records' room)."""
    records: cl.Buffer
    filtered: cl.Buffer
    samples: int
    samples_per_pass: int


def render(scene, spp=None, device=None, seed=None, max_depth=None, progress=None, volume_method=None,
           step=None, denoise=False, sampler=None):
    """Render `scene` (a Scene, a scene dict or a file path) and return the linear float32
    (H, W, 3) image (denoised if `denoise`); `sampler` overrides render.sampler; `progress`: a
    callable, or True for a bar on stderr (Renderer.render)."""
    return Renderer(scene, device, volume_method=volume_method, step=step, sampler=sampler).render(
        spp=spp, seed=seed, max_depth=max_depth, progress=progress, denoise=denoise).image
