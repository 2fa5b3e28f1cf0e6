"""Progressive rendering: short kernel launches that each add a few samples per pixel."""
import signal
import time
from dataclasses import dataclass

import numpy as np
import pyopencl as cl

from . import layout, limits
from .outlines import apply_outlines, aux_dict
from .arrays import build_scene_arrays
from .device import build_program, choose_device, device_errors
from .energy import fill_albedo_tables
from .errors import ArgumentError
from .features import scene_features
from .scene import as_scene


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

    @property
    def samples_per_second(self):
        h, w, _ = self.image.shape
        return self.samples * w * h / self.seconds if self.seconds > 0 else 0.0


MAX_SPP = limits.MAX_SPP   # per-pixel sample counts are float32 in the accumulator


def render_params(scene, arrays, first_sample, samples, max_depth, rr_depth, seed, spectral_mis=True,
                  step=None, raymarch_multiple_scattering=None):
    """The RenderParams struct of one launch. `step` and `raymarch_multiple_scattering` (ray
    marching of grid media) default to the scene's render settings."""
    camera = scene.camera
    width, height = camera.resolution
    forward, right, up = camera.basis()
    p = np.zeros(1, layout.RENDER_PARAMS)
    p["camera"]["origin"][0, :3] = camera.position * arrays.length_scale
    p["camera"]["forward"][0, :3] = forward
    p["camera"]["right"][0, :3] = right
    p["camera"]["up"][0, :3] = up
    p["frame"] = (width, height, first_sample, samples)
    # The kernel reads the seed as uint (0..2^32-1): store its bits in the int4's slot.
    p["config"] = (max_depth, rr_depth, np.array(seed, np.uint32).view(np.int32), len(arrays.emitters))
    p["environment"] = (arrays.env_index, *arrays.env_size, 0)
    p["media"] = (arrays.camera_medium, int(spectral_mis), 0, 0)
    settings = scene.render
    step = settings.step if step is None else step
    multiple = (settings.raymarch_multiple_scattering if raymarch_multiple_scattering is None
                else raymarch_multiple_scattering)
    # A step beyond float32 (a tiny scene keeping the default) is one step through anything.
    step = min(step * arrays.length_scale, limits.FLOAT32_MAX)
    p["volume"] = (step, float(bool(multiple)), 0, 0)
    p["scene_sphere"] = arrays.scene_sphere
    p["lights"] = (arrays.first_light, 0, 0, 0)
    return p


class RenderInterrupted(KeyboardInterrupt):
    """Ctrl-C (or SIGTERM/SIGHUP, see errors.Interrupted) during a render; `result` holds the
    image of the samples completed so far, `signal` the signal number."""

    def __init__(self, result, signum=signal.SIGINT):
        super().__init__("render interrupted")
        self.result = result
        self.signal = signum


class Renderer:
    """A scene uploaded to one device with its specialised kernel, ready to render many times."""

    @device_errors()
    def __init__(self, scene, device=None, local_size=None, pass_seconds=0.25, spectral_mis=True,
                 volume_method=None, step=None, raymarch_multiple_scattering=None):
        """`scene`: a Scene, a scene dict or a file path. `device`: an OpenCL device, a context
        (whose built programs are reused), or a choice for `choose_device`. `volume_method`
        ("null" or "raymarch"), `step` (> 0, scene units) and `raymarch_multiple_scattering`
        override the scene's render settings for grid media."""
        self.scene = scene = as_scene(scene)
        step = None if step is None else limits.setting("step", step)
        limits.number(pass_seconds, "pass_seconds", low=0.0, low_open=True)
        if isinstance(device, cl.Context):
            self.context, self.device = device, device.devices[0]
        else:
            self.device = device if isinstance(device, cl.Device) else choose_device(device)
            self.context = cl.Context([self.device])
        self.queue = cl.CommandQueue(self.context)
        self.features = scene_features(scene, volume_method)
        self.step = step
        self.raymarch_multiple_scattering = raymarch_multiple_scattering
        limits.check_image_fits(scene.camera.resolution, self.device)
        self.arrays = build_scene_arrays(scene)
        limits.check_arrays_fit({name: getattr(self.arrays, name) for name in self.ARRAYS}, self.device)
        program = build_program(self.context, self.features)
        self.kernel = cl.Kernel(program, "render_pass")
        self.local_size = local_size
        self.pass_seconds = pass_seconds
        self.spectral_mis = spectral_mis
        fill_albedo_tables(self.queue, program, self.arrays)
        self._buffers = [self._upload(getattr(self.arrays, name)) for name in self.ARRAYS]

    # The scene arrays passed to the kernel, in argument order after the RenderParams.
    ARRAYS = ("nodes", "triangles", "shading", "info", "materials", "media", "emitters",
              "emitter_cdf", "env_texels", "env_cdf", "specular_albedo", "grid_data", "majorant_data")

    def update_array(self, name, array):
        """Replace one of the scene arrays on the device (same dtype and meaning), e.g. an
        edited density grid (`grid_data`, with its `majorant_data`) between renders."""
        if name not in self.ARRAYS:
            raise ArgumentError("name", f"unknown array {name!r}; valid: {', '.join(self.ARRAYS)}")
        index = self.ARRAYS.index(name)
        array = np.asarray(array, dtype=getattr(self.arrays, name).dtype)
        setattr(self.arrays, name, array)
        self._buffers[index] = self._upload(array)

    def _upload(self, array):
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        data = array if array.size else np.zeros(1, array.dtype)
        return cl.Buffer(self.context, flags, hostbuf=np.ascontiguousarray(data))

    @device_errors()
    def render(self, spp=None, seed=None, max_depth=None, rr_depth=None, progress=None,
               samples_per_pass=None, time_limit=None):
        """Render and return a RenderResult. `progress(samples_done, spp, seconds)` is called
        after every launch. Samples per launch adapt to `pass_seconds` unless fixed by
        `samples_per_pass`; the image does not depend on the split. With `time_limit` (seconds of
        kernel time) rendering stops after the launch that reaches it, or at `spp` if given."""
        settings = self.scene.render
        given = dict(spp=spp, seed=seed, max_depth=max_depth, rr_depth=rr_depth,
                     samples_per_pass=samples_per_pass, time_limit=time_limit)
        for name, value in given.items():
            if value is not None:
                limits.setting(name, value)
        if spp is None:
            spp = MAX_SPP if time_limit is not None else settings.spp
        seed = settings.seed if seed is None else seed
        max_depth = settings.max_depth if max_depth is None else max_depth
        rr_depth = settings.rr_depth if rr_depth is None else rr_depth
        width, height = self.scene.camera.resolution
        mf = cl.mem_flags
        accumulator = np.zeros((height * width, 4), np.float32)
        accum_buffer = cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=accumulator)
        discarded = np.zeros(1, np.int32)
        discarded_buffer = cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=discarded)
        # Written by the launch holding sample 0 (every render starts there).
        aux_buffers = (cl.Buffer(self.context, mf.WRITE_ONLY, height * width * 16),
                       cl.Buffer(self.context, mf.WRITE_ONLY, height * width * 4))
        params_buffer = cl.Buffer(self.context, mf.READ_ONLY, layout.RENDER_PARAMS.itemsize)
        global_size = self._global_size(width, height)

        done, per_pass, seconds = 0, samples_per_pass or 1, 0.0
        try:
            while done < spp and (time_limit is None or seconds < time_limit):
                count = min(per_pass, spp - done)
                params = render_params(self.scene, self.arrays, done, count, max_depth, rr_depth,
                                       seed, self.spectral_mis, self.step, self.raymarch_multiple_scattering)
                cl.enqueue_copy(self.queue, params_buffer, params)
                start = time.perf_counter()
                self.kernel(self.queue, global_size, self.local_size, params_buffer,
                            *self._buffers, accum_buffer, discarded_buffer, *aux_buffers)
                self.queue.finish()
                elapsed = time.perf_counter() - start
                seconds += elapsed
                done += count
                if samples_per_pass is None:
                    per_pass = self._next_pass_size(count, elapsed)
                if progress is not None:
                    progress(done, spp, seconds)
        except KeyboardInterrupt as interrupt:
            self.queue.finish()
            raise RenderInterrupted(self._result(accum_buffer, discarded_buffer, aux_buffers, seconds),
                                    getattr(interrupt, "signal", signal.SIGINT)) from None
        return self._result(accum_buffer, discarded_buffer, aux_buffers, seconds)

    def _global_size(self, width, height):
        if self.local_size is None:
            return (width, height)
        lx, ly = self.local_size
        return (-(-width // lx) * lx, -(-height // ly) * ly)

    def _next_pass_size(self, count, elapsed):
        if elapsed <= 0:
            return count * 2
        target = int(count * self.pass_seconds / elapsed)
        return max(1, min(target, count * 4))

    def _result(self, accum_buffer, discarded_buffer, aux_buffers, seconds):
        width, height = self.scene.camera.resolution
        accumulator = np.empty((height * width, 4), np.float32)
        discarded = np.empty(1, np.int32)
        geometry = np.empty((height * width, 4), np.float32)
        object_id = np.empty(height * width, np.int32)
        cl.enqueue_copy(self.queue, accumulator, accum_buffer)
        cl.enqueue_copy(self.queue, discarded, discarded_buffer)
        cl.enqueue_copy(self.queue, geometry, aux_buffers[0])
        cl.enqueue_copy(self.queue, object_id, aux_buffers[1])
        geometry[:, 3] /= self.arrays.length_scale      # depth in scene units
        # The w channel counts the samples each pixel received, so an interrupted render is
        # normalised exactly by what was done.
        counts = accumulator[:, 3:4]
        image = np.where(counts > 0, accumulator[:, :3] / np.maximum(counts, 1), 0.0)
        image = image.reshape(height, width, 3).astype(np.float32)
        aux = aux_dict(geometry, object_id, width, height)
        image, alpha = apply_outlines(image, aux, self.scene.outlines)
        return RenderResult(image, int(counts.min()) if counts.size else 0, seconds,
                            int(discarded[0]), aux=aux, outline_alpha=alpha)


def render(scene, spp=None, device=None, seed=None, max_depth=None, progress=None, volume_method=None,
           step=None):
    """Render `scene` (a Scene, a scene dict or a file path) and return the linear float32
    (H, W, 3) image."""
    return Renderer(scene, device, volume_method=volume_method, step=step).render(
        spp=spp, seed=seed, max_depth=max_depth, progress=progress).image
