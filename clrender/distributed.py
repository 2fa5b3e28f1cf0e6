"""Distributed rendering on a Dask cluster, bit-identical to a local render.

The kernel adds each pixel's samples one by one, in index order, onto its running sum, and float
addition is not associative: sums of separate sample ranges, each started from zero and added
afterwards, differ from a local render in the last bits. So the work is split the other way: the
image into tiles (horizontal strips: the parallelism), and each tile's samples into chunks that
run one after another, each continuing from the sums its predecessor returned
(`Renderer.accumulate`). Every pixel's sum is built exactly as in one local render, and the tiles
are laid side by side, never added.

The client drives the chains. A finished chunk's Accumulation comes back to the client, where it
is the progress, the checkpoint and (on Ctrl-C) the partial image, and goes out again with the
tile's next chunk. So a chunk depends on no other task: Dask places it on any free worker, and a
worker that dies loses only its chunks in flight, which Dask reruns elsewhere.

Each worker process keeps a Renderer (device context, built program, scene buffers) per scene; the
scene is scattered to every worker once, not shipped per task. docs/distributed.md has the
design, the set-up of a cluster and the measured scaling.
"""
import logging
import math
import signal
import threading
import time
import uuid
import warnings
from collections import OrderedDict
from contextlib import contextmanager
from dataclasses import replace

import numpy as np

from .render import MAX_SPP, Accumulation, RenderInterrupted, image_result

CHUNK_SECONDS = 3.0        # target kernel time of a chunk: seconds, so per-chunk overhead is small
TILE_PIXELS = 256 * 1024   # most pixels in a tile: bounds what a task carries (16 bytes a pixel)
TILES_PER_THREAD = 4       # so a worker has chunks queued while the client answers a finished one
RETRIES = 2                # reruns of a chunk that raised, before the render fails
SCENES_IN_FLIGHT = 2       # a batch starts the next scene while the last chunks of one finish


class DistributedRenderError(RuntimeError):
    """A chunk failed on every try; the message names the worker."""


# ----- client --------------------------------------------------------------------------------

def render(scene, client, spp=None, seed=None, max_depth=None, device=None, volume_method=None,
           step=None, raymarch_multiple_scattering=None, tiles=None, chunk_seconds=CHUNK_SECONDS,
           samples_per_chunk=None, progress=None):
    """Render `scene` on the Dask cluster of `client` (a distributed.Client) and return a
    RenderResult whose image is exactly (bit for bit) that of `clrender.render(scene, spp, ...)`
    on the workers' kind of device.

    `device` is the device spec every worker uses (default: each worker's $CLRENDER_DEVICE, else
    its GPU, else its CPU). `tiles`: horizontal strips to split the image into (default: 4 per
    worker thread, at most TILE_PIXELS each). Chunks are sized to take `chunk_seconds` of kernel
    time from the rate of the tile's previous chunk (the first chunk of a tile takes one sample);
    `samples_per_chunk` fixes their size instead. `progress(spp_done, spp, seconds)` follows each
    chunk, with spp_done averaged over the pixels and `seconds` wall time. RenderResult.seconds
    is wall time, so samples_per_second is the cluster's rate.

    Ctrl-C cancels the chunks in flight and raises RenderInterrupted whose result holds the image
    merged so far, each pixel normalised by its own sample count."""
    spp = scene.render.spp if spp is None else spp

    def frame_progress(frames_done, frames, seconds):
        progress(frames_done * spp, spp, seconds)

    results = render_many([scene], client, spp, seed, max_depth, device, volume_method, step,
                          raymarch_multiple_scattering, tiles, chunk_seconds, samples_per_chunk,
                          frame_progress if progress else None)
    try:
        for _, result in results:
            return result
    except RenderInterrupted as interrupted:
        if not interrupted.result:
            raise KeyboardInterrupt from None
        raise RenderInterrupted(interrupted.result[0][1]) from None
    finally:
        results.close()


def render_many(scenes, client, spp=None, seed=None, max_depth=None, device=None, volume_method=None,
                step=None, raymarch_multiple_scattering=None, tiles=None, chunk_seconds=CHUNK_SECONDS,
                samples_per_chunk=None, progress=None, scenes_in_flight=SCENES_IN_FLIGHT):
    """Render many scenes on the cluster and yield (index, RenderResult) as each completes.

    `scenes` may be any iterable (e.g. a generator loading files): it is consumed as scenes are
    started, `scenes_in_flight` at a time, earlier scenes first. `spp` None: each scene's own.
    `progress(frames_done, frames, seconds)`: frames_done counts finished scenes plus the
    completed fraction of those in flight; frames is len(scenes), or None for an iterator. The
    other arguments are those of `render`. Ctrl-C cancels the chunks in flight and raises
    RenderInterrupted whose result is the list of (index, partial RenderResult) of the scenes in
    flight."""
    if samples_per_chunk is not None and samples_per_chunk < 1:
        raise ValueError(f"samples_per_chunk must be >= 1, got {samples_per_chunk}")
    if not chunk_seconds > 0:
        raise ValueError(f"chunk_seconds must be positive, got {chunk_seconds}")
    as_completed = _dask().as_completed
    options = (device, volume_method, step, raymarch_multiple_scattering, seed, max_depth)
    token = uuid.uuid4().hex[:8]
    frames = len(scenes) if hasattr(scenes, "__len__") else None
    waiting = iter(enumerate(scenes))
    jobs, running = {}, {}        # scene index -> _Job; future key -> (job, tile index, future)
    finished = as_completed(loop=client.loop, with_results=True)   # not the default client's loop
    frames_done, start = 0, time.perf_counter()

    def submit(job, tile):
        state = job.states[tile]
        count = job.next_chunk(tile, chunk_seconds, samples_per_chunk)
        # The aux buffers stay on the client: only chunks from sample 0 write them.
        outgoing = replace(state, geometry=None, object_id=None)
        future = client.submit(_render_chunk, job.scene_future, job.scene_future.key, options,
                               outgoing, count, key=f"clrender-chunk-{token}-{job.index}-{tile}-{state.samples}",
                               priority=-(job.index * (MAX_SPP + 1) + state.samples), retries=RETRIES)
        running[future.key] = (job, tile, future)
        finished.add(future)

    def start_scenes():
        while len(jobs) < scenes_in_flight:
            index, scene = next(waiting, (None, None))
            if scene is None:
                return
            count = scene.render.spp if spp is None else spp
            if not 1 <= count <= MAX_SPP:
                raise ValueError(f"spp must be in 1..{MAX_SPP}, got {count}")
            width, height = scene.camera.resolution
            strips = tiles or max(TILES_PER_THREAD * max(1, sum(client.nthreads().values())),
                                  math.ceil(width * height / TILE_PIXELS))
            job = _Job(index, scene, client.scatter(scene, broadcast=True, hash=False), count,
                       horizontal_strips(width, height, strips))
            jobs[index] = job
            for tile in range(len(job.states)):
                submit(job, tile)

    try:
        start_scenes()
        for future, (state, device_name) in _chunk_results(finished):
            job, tile, _ = running.pop(future.key)
            job.update(tile, state, device_name)
            if state.samples < job.spp:
                submit(job, tile)
            elif job.complete():
                del jobs[job.index]
                job.scene_future.release()
                frames_done += 1
                yield job.index, job.result()
                start_scenes()
            if progress is not None:
                progress(frames_done + sum(j.fraction() for j in jobs.values()), frames,
                         time.perf_counter() - start)
    except KeyboardInterrupt:
        _cancel(client, running)
        raise RenderInterrupted([(j.index, j.result()) for j in jobs.values()]) from None
    finally:
        _cancel(client, running)
        for job in jobs.values():
            job.scene_future.release()


@contextmanager
def dask_client(workers=None, scheduler=None, timeout=60):
    """A distributed.Client of a new LocalCluster of `workers` processes with one thread each
    (one device context each), or of the cluster whose scheduler is at `scheduler`
    (tcp://HOST:PORT), waiting up to `timeout` seconds for its first worker."""
    dask_distributed = _dask()
    if scheduler:
        with dask_distributed.Client(scheduler, timeout=timeout) as client:
            try:
                client.wait_for_workers(1, timeout=timeout)
            except TimeoutError:
                raise DistributedRenderError(f"no worker joined the scheduler at {scheduler} within "
                                             f"{timeout} s; start one with `dask worker {scheduler}`") from None
            yield client
        return
    # Chunk failures reach the client as exceptions; the workers' own logs (e.g. a heartbeat cut
    # off when the cluster closes after Ctrl-C) would only be tracebacks on the terminal.
    cluster = dask_distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                            dashboard_address=":0", silence_logs=logging.CRITICAL,
                                            preload=[__name__])
    with cluster, dask_distributed.Client(cluster) as client:
        yield client


def dask_setup(worker):
    """Dask's preload hook, run as each worker of `dask_client`'s LocalCluster starts (restarts
    too): Ctrl-C in the terminal reaches these processes as well; they ignore it, and the client
    cancels their chunks and writes what it has."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def horizontal_strips(width, height, count):
    """About `count` strips (x, y, width, rows) covering the image top to bottom, all of the same
    rows but the last: PoCL compiles the kernel once per launch shape."""
    rows = math.ceil(height / max(1, min(int(count), height)))
    return [(0, top, width, min(rows, height - top)) for top in range(0, height, rows)]


def merge_strips(scene, states):
    """The whole-image Accumulation of the strips' Accumulations (top to bottom): laid side by
    side, never added. A strip without its aux buffers yet (no chunk done) reads as escaped rays."""
    width, height = scene.camera.resolution
    geometry = [s.geometry if s.geometry is not None else np.zeros((len(s.sums), 4), np.float32)
                for s in states]
    object_id = [s.object_id if s.object_id is not None else np.full(len(s.sums), -1, np.int32)
                 for s in states]
    return Accumulation((0, 0, width, height), min(s.samples for s in states),
                        np.concatenate([s.sums for s in states]), sum(s.discarded for s in states),
                        sum(s.seconds for s in states), np.concatenate(geometry),
                        np.concatenate(object_id))


class _Job:
    """A scene in flight: its scattered copy and the latest Accumulation of each strip."""

    def __init__(self, index, scene, scene_future, spp, strips):
        self.index, self.scene, self.scene_future, self.spp = index, scene, scene_future, spp
        self.states = [Accumulation.start(strip) for strip in strips]
        self.last_chunk = [(0, 0.0)] * len(strips)   # (samples, kernel seconds) of the latest chunk
        self.devices = set()
        self.started = time.perf_counter()

    def next_chunk(self, tile, chunk_seconds, samples_per_chunk):
        remaining = self.spp - self.states[tile].samples
        samples, seconds = self.last_chunk[tile]
        if samples_per_chunk is not None:
            return min(samples_per_chunk, remaining)
        if samples == 0:
            return 1   # calibration: the rate is not known yet
        target = int(samples * chunk_seconds / max(seconds, 1e-6))
        # At most half of what is left: the last chunks shrink, so the workers finish together.
        return max(1, min(target, 16 * samples, math.ceil(remaining / 2)))

    def update(self, tile, state, device_name):
        previous = self.states[tile]
        self.last_chunk[tile] = (state.samples - previous.samples, state.seconds - previous.seconds)
        if state.geometry is None:
            state = replace(state, geometry=previous.geometry, object_id=previous.object_id)
        self.states[tile] = state
        self.devices.add(device_name)

    def complete(self):
        return all(s.samples == self.spp for s in self.states)

    def fraction(self):
        pixels = sum(len(s.sums) for s in self.states)
        return sum(s.samples * len(s.sums) for s in self.states) / (self.spp * pixels)

    def result(self):
        if len(self.devices) > 1:
            warnings.warn(f"scene {self.index} was rendered on {len(self.devices)} kinds of device "
                          f"({'; '.join(sorted(self.devices))}): a valid image, but not bit-identical "
                          "to a render on one of them", stacklevel=3)
        result = image_result(self.scene, merge_strips(self.scene, self.states))
        result.seconds = time.perf_counter() - self.started
        return result


def _dask():
    """The `distributed` package, or an error saying how to install it."""
    try:
        import distributed
    except ImportError:
        raise DistributedRenderError("distributed rendering needs Dask: pip install 'clrender[distributed]' "
                                     "(or 'dask[distributed]')") from None
    return distributed


def _chunk_results(finished):
    """(future, result) of each chunk as it finishes; a chunk's failure as DistributedRenderError."""
    try:
        yield from finished
    except DistributedRenderError:
        raise
    except Exception as e:   # KilledWorker: every worker that ran the chunk died
        raise DistributedRenderError(f"chunk failed: {type(e).__name__}: {e}") from None


def _cancel(client, running):
    if running:
        client.cancel([future for _, _, future in running.values()])
        running.clear()


# ----- worker --------------------------------------------------------------------------------

_renderers = OrderedDict()   # per worker process: (scene key, options) -> Renderer, latest last
_contexts = {}               # device -> the cl.Context its renderers share (programs built once)
_device_lock = threading.Lock()
RENDERERS_KEPT = SCENES_IN_FLIGHT + 1


def _render_chunk(scene, scene_key, options, state, samples):
    """Dask task: add `samples` samples to the strip `state` on this worker's device. Returns
    (Accumulation, device description)."""
    x, y, width, rows = state.tile
    try:
        with _device_lock:   # one chunk at a time on the device, however many threads
            renderer = _worker_renderer(scene, scene_key, *options[:4])
            result = renderer.accumulate(state, samples, *options[4:])
    except Exception as e:
        raise DistributedRenderError(
            f"worker {_worker_address()}: rows {y}..{y + rows - 1}, samples {state.samples}.."
            f"{state.samples + samples - 1}: {type(e).__name__}: {e}") from None
    device = renderer.device
    return result, f"{device.name.strip()} [{device.platform.name.strip()}, driver {device.driver_version}]"


def _worker_renderer(scene, scene_key, device, volume_method, step, raymarch_multiple_scattering):
    """This process's Renderer of the scattered scene `scene_key`, built on first use."""
    from .device import choose_device
    from .render import Renderer

    key = (scene_key, device, volume_method, step, raymarch_multiple_scattering)
    renderer = _renderers.pop(key, None)
    if renderer is None:
        cl_device = choose_device(device)
        context = _contexts.get(cl_device.int_ptr)
        renderer = Renderer(scene, cl_device, volume_method=volume_method, step=step,
                            raymarch_multiple_scattering=raymarch_multiple_scattering, context=context)
        _contexts[cl_device.int_ptr] = renderer.context
    _renderers[key] = renderer
    while len(_renderers) > RENDERERS_KEPT:
        _renderers.popitem(last=False)
    return renderer


def _worker_address():
    try:
        from distributed import get_worker

        worker = get_worker()
        return f"{worker.address} (name {worker.name})"
    except ValueError:
        return "(not a Dask worker)"
