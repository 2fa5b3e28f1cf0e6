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
import socket
import struct
import threading
import time
import uuid
import warnings
from collections import OrderedDict
from concurrent.futures import CancelledError
from contextlib import contextmanager
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from . import limits
from .errors import ArgumentError, ClrenderError, DeviceError, MissingDependency
from .features import scene_features
from .aovs import needs_sample_aovs
from .render import MAX_SPP, Accumulation, RenderInterrupted, image_result, output_request, sampler_code
from .scene import as_scene
from .signals import signals_deferred

CHUNK_SECONDS = 3.0        # target kernel time of a chunk: seconds, so per-chunk overhead is small
TILE_PIXELS = 256 * 1024   # most pixels in a tile: bounds what a task carries (16 bytes a pixel)
TILES_PER_THREAD = 4       # so a worker has chunks queued while the client answers a finished one
RETRIES = 2                # reruns of a chunk that raised, before the render fails
SCENES_IN_FLIGHT = 2       # a batch starts the next scene while the last chunks of one finish
CONNECT_TIMEOUT = 30.0     # seconds to reach the scheduler, and for a first worker to join it
CHUNK_TIMEOUT = 600.0      # seconds without any chunk finishing before the render fails (a first
                           # chunk builds the kernel: up to a minute on a slow CPU)
MAX_HANDSHAKE_BYTES = 2**20   # a Dask scheduler's greeting is a few hundred bytes


class DistributedRenderError(DeviceError):
    """The cluster cannot do the work: its scheduler cannot be reached, no worker joined, or a
    chunk failed on every try (the message names the worker). An error of clrender's own on a
    worker (a bad scene or device choice) keeps its class instead."""


# ----- client --------------------------------------------------------------------------------

def render(scene, client, spp=None, seed=None, max_depth=None, device=None, volume_method=None,
           step=None, raymarch_multiple_scattering=None, tiles=None, chunk_seconds=CHUNK_SECONDS,
           samples_per_chunk=None, progress=None, aovs=None, denoise=False, denoise_prefilter=False,
           denoise_keep_emission=False, sampler=None, chunk_timeout=None):
    """Render `scene` on the Dask cluster of `client` (a distributed.Client) and return a
    RenderResult whose image is exactly (bit for bit) that of `clrender.render(scene, spp, ...)`
    on the workers' kind of device.

    `device` is the device spec every worker uses (default: each worker's $CLRENDER_DEVICE, else
    its GPU, else its CPU). `tiles`: horizontal strips to split the image into (default: 4 per
    worker thread, at most TILE_PIXELS each). Chunks are sized to take `chunk_seconds` of kernel
    time from the rate of the tile's previous chunk (the first chunk of a tile takes one sample);
    `samples_per_chunk` fixes their size instead. `progress(spp_done, spp, seconds)` follows each
    chunk, with spp_done averaged over the pixels and `seconds` wall time. RenderResult.seconds
    is wall time, so samples_per_second is the cluster's rate. `aovs` (None: the scene's) and the
    denoising arguments are those of `Renderer.render`: the AOVs are accumulated with the colour, chunk by
    chunk, so they are bit-identical to a local render's too. `sampler` overrides the scene's
    render.sampler, as in `Renderer`. `chunk_timeout`: seconds without any chunk finishing
    after which the render fails (DistributedRenderError), e.g. on a cluster whose workers hang.

    Ctrl-C cancels the chunks in flight and raises RenderInterrupted whose result holds the image
    merged so far, each pixel normalised by its own sample count."""
    scene = as_scene(scene)
    spp = scene.render.spp if spp is None else spp

    def frame_progress(frames_done, frames, seconds):
        progress(frames_done * spp, spp, seconds)

    results = render_many([scene], client, spp, seed, max_depth, device, volume_method, step,
                          raymarch_multiple_scattering, tiles, chunk_seconds, samples_per_chunk,
                          frame_progress if progress else None,
                          aovs=scene.render.aovs if aovs is None else aovs, denoise=denoise,
                          denoise_prefilter=denoise_prefilter, denoise_keep_emission=denoise_keep_emission,
                          sampler=sampler, chunk_timeout=chunk_timeout)
    try:
        for _, result in results:
            return result
    except RenderInterrupted as interrupted:
        if not interrupted.result:
            raise KeyboardInterrupt from None
        raise RenderInterrupted(interrupted.result[0][1], interrupted.signal) from None
    finally:
        results.close()


def render_many(scenes, client, spp=None, seed=None, max_depth=None, device=None, volume_method=None,
                step=None, raymarch_multiple_scattering=None, tiles=None, chunk_seconds=CHUNK_SECONDS,
                samples_per_chunk=None, progress=None, scenes_in_flight=SCENES_IN_FLIGHT, aovs=(),
                denoise=False, denoise_prefilter=False, denoise_keep_emission=False, sampler=None,
                chunk_timeout=None):
    """Render many scenes on the cluster and yield (index, RenderResult) as each completes.

    `scenes` may be any iterable (e.g. a generator loading files): it is consumed as scenes are
    started, `scenes_in_flight` at a time, earlier scenes first. `spp` None: each scene's own.
    `progress(frames_done, frames, seconds)`: frames_done counts finished scenes plus the
    completed fraction of those in flight; frames is len(scenes), or None for an iterator.
    `aovs`: the same AOVs for every scene (not the scenes' own render.aovs). The other arguments
    are those of `render`. Ctrl-C cancels the chunks in flight and raises
    RenderInterrupted whose result is the list of (index, partial RenderResult) of the scenes in
    flight with at least one chunk done (a scene started but not yet rendered is left out, as a
    local batch leaves the scenes after the one interrupted); Ctrl-C's signal (SIGTERM, SIGHUP in the CLI) is its `signal`. The arguments are
    checked as by `Renderer.render` (limits.py) by this call, each scene as it starts: before
    anything is sent to the cluster (ArgumentError)."""
    limits.check_settings(spp=spp, seed=seed, max_depth=max_depth, step=step, tiles=tiles,
                          chunk_seconds=chunk_seconds, samples_per_chunk=samples_per_chunk,
                          scenes_in_flight=scenes_in_flight, chunk_timeout=chunk_timeout)
    require_dask()
    chunk_timeout = CHUNK_TIMEOUT if chunk_timeout is None else chunk_timeout
    outputs = output_request(aovs, denoise, denoise_prefilter, denoise_keep_emission)
    options = (device, volume_method, step, raymarch_multiple_scattering, sampler, seed, max_depth)
    return _render_many(scenes, client, spp, volume_method, options, tiles, chunk_seconds, samples_per_chunk,
                        progress, scenes_in_flight, outputs, chunk_timeout)


def _render_many(scenes, client, spp, volume_method, options, tiles, chunk_seconds, samples_per_chunk,
                 progress, scenes_in_flight, outputs, chunk_timeout):
    """The generator of render_many, its arguments checked."""
    from distributed import as_completed

    token = uuid.uuid4().hex[:8]
    frames = len(scenes) if hasattr(scenes, "__len__") else None
    waiting = iter(enumerate(scenes))
    jobs, running = {}, {}        # scene index -> _Job; future key -> _Chunk
    finished = as_completed(loop=client.loop, with_results=True)   # not the default client's loop
    frames_done, start = 0, time.perf_counter()

    def submit(job, tile):
        state = job.states[tile]
        count = job.next_chunk(tile, chunk_seconds, samples_per_chunk)
        # The aux buffers stay on the client: only chunks from sample 0 write them.
        outgoing = replace(state, geometry=None, object_id=None)
        key = f"clrender-chunk-{token}-{job.index}-{tile}-{state.samples}-{job.scatters}"
        future = client.submit(_render_chunk, job.scene_future, job.scene_future.key, options, outgoing, count,
                               key=key, priority=-(job.index * (MAX_SPP + 1) + state.samples), retries=RETRIES)
        running[future.key] = _Chunk(job, tile, future, job.scene_future)
        finished.add(future)

    def submit_again(chunk):
        """A chunk the cluster cancelled, submitted again: its scene was lost with every worker
        that held it (workers killed, or the one that had joined when it was scattered), so it is
        scattered again first, at most RETRIES times a scene."""
        job = chunk.job
        _raise_a_failure(c.future for c in running.values())   # a chunk dead on every try ends the render
        if chunk.scene is job.scene_future:   # not scattered again since this chunk was submitted
            if job.scatters == RETRIES:
                raise DistributedRenderError(f"the workers holding scene {job.index} were lost {RETRIES + 1} times "
                                             f"on the cluster of {_scheduler_address(client)}")
            job.scene_future.release()
            with _cluster_errors(client):
                job.scene_future = client.scatter(job.scene, broadcast=True, hash=False, timeout=chunk_timeout)
            job.scatters += 1
        submit(job, chunk.tile)

    def start_scenes():
        while len(jobs) < scenes_in_flight:
            index, scene = next(waiting, (None, None))
            if scene is None:
                return
            scene = as_scene(scene)
            scene_features(scene, volume_method)   # checks the method here, not on every worker
            sampler_code(scene, options[4])        # and the sampler
            count = limits.setting("spp", scene.render.spp if spp is None else spp)
            width, height = scene.camera.resolution
            strips = tiles or max(TILES_PER_THREAD * max(1, sum(client.nthreads().values())),
                                  math.ceil(width * height / TILE_PIXELS))
            scattered = client.scatter(scene, broadcast=True, hash=False, timeout=chunk_timeout)   # waits for a worker
            job = _Job(index, scene, scattered, count,
                       horizontal_strips(width, height, strips), *outputs)
            jobs[index] = job
            for tile in range(len(job.states)):
                submit(job, tile)

    try:
        with _cluster_errors(client):
            start_scenes()
        chunks = _chunk_results(finished, lambda: [chunk.future for chunk in running.values()], chunk_timeout,
                                client)
        for future, result in chunks:
            chunk = running.pop(future.key, None)
            if chunk is None:   # cancelled here
                continue
            if future.status == "cancelled":
                submit_again(chunk)
                continue
            job, tile, (state, device_name) = chunk.job, chunk.tile, result
            job.update(tile, state, device_name)
            if state.samples < job.spp:
                submit(job, tile)
            elif job.complete():
                del jobs[job.index]
                job.scene_future.release()
                frames_done += 1
                yield job.index, job.result()
                with _cluster_errors(client):
                    start_scenes()
            if progress is not None:
                progress(frames_done + sum(j.fraction() for j in jobs.values()), frames,
                         time.perf_counter() - start)
    except KeyboardInterrupt as interrupt:
        _cancel(client, running)
        raise RenderInterrupted([(j.index, j.result()) for j in jobs.values() if j.fraction() > 0],
                                getattr(interrupt, "signal", signal.SIGINT)) from None
    finally:
        _cancel(client, running)
        for job in jobs.values():
            job.scene_future.release()


@contextmanager
def dask_client(workers=None, scheduler=None, timeout=None):
    """A distributed.Client of a new LocalCluster of `workers` processes with one thread each
    (one device context each), or of the cluster whose scheduler is at `scheduler`
    (tcp://HOST:PORT), reached within `timeout` seconds (None: CONNECT_TIMEOUT), and waiting as
    long for its first worker. Every failure to connect is a DistributedRenderError naming the
    address."""
    timeout = CONNECT_TIMEOUT if timeout is None else limits.setting("connect_timeout", timeout)
    dask_distributed = require_dask("scheduler" if scheduler is not None else "workers")
    if scheduler is not None:
        with _client_callbacks_quiet(), _connect(dask_distributed, scheduler, timeout) as client:
            try:
                client.wait_for_workers(1, timeout=timeout)
            except (TimeoutError, OSError) as e:
                raise DistributedRenderError(f"no worker joined the scheduler at {scheduler} within "
                                             f"{timeout:g} s ({type(e).__name__}); start one with "
                                             f"`dask worker {scheduler}`") from None
            yield client
        return
    _start_resource_tracker()
    # Chunk failures reach the client as exceptions; the workers' own logs (e.g. a heartbeat cut
    # off when the cluster closes after Ctrl-C) would only be tracebacks on the terminal.
    with signals_deferred():   # a cluster interrupted while its workers start cannot be closed
        cluster = dask_distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                                dashboard_address=":0", silence_logs=logging.CRITICAL,
                                                preload=[__name__])
    with _client_callbacks_quiet(), cluster, dask_distributed.Client(cluster) as client:
        yield client


@contextmanager
def _client_callbacks_quiet():
    """Dask's client loop logs, through tornado, the failure of each result it was still fetching
    when its connection closes (after Ctrl-C or SIGTERM): tracebacks on the terminal for chunks
    cancelled anyway (1 run in dozens of tests/test_distributed.py's double SIGTERM). Failures that
    matter reach the render as exceptions."""
    logger = logging.getLogger("tornado.application")
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        logger.setLevel(level)


def _start_resource_tracker():
    """Start multiprocessing's resource tracker (which a LocalCluster uses) with SIGHUP ignored,
    as the workers ignore it (dask_setup): a closed terminal's hang-up reaches the whole process
    group, and the tracker, which ignores only SIGINT and SIGTERM, would die and be relaunched
    with tracebacks while the client writes its partial images. An ignored signal stays ignored
    in a child process."""
    from multiprocessing import resource_tracker

    if threading.current_thread() is not threading.main_thread():   # signal.signal needs it
        resource_tracker.ensure_running()
        return
    previous = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        resource_tracker.ensure_running()
    finally:
        signal.signal(signal.SIGHUP, previous)


def _connect(dask_distributed, scheduler, timeout):
    """A distributed.Client of the scheduler at `scheduler`: a string that is not an address is
    an ArgumentError; a scheme other than tcp://, an address that cannot be reached, or one that
    does not greet as a Dask scheduler within `timeout` (a socket that never answers, a web
    server) a DistributedRenderError naming it."""
    from distributed.comm.addressing import parse_address, parse_host_port

    if not isinstance(scheduler, str) or not scheduler.strip():
        raise ArgumentError("scheduler", f"expected tcp://HOST:PORT, got {limits.show(scheduler)}")
    try:
        scheme, location = parse_address(scheduler)
        host, port = parse_host_port(location)
    except ValueError as e:   # not an address: 'missing port number'
        raise ArgumentError("scheduler", f"{e}; expected tcp://HOST:PORT") from None
    if not 0 < port <= 65535:
        raise ArgumentError("scheduler", f"port {port} is not a port number; expected tcp://HOST:PORT")
    if scheme != "tcp":
        raise DistributedRenderError(f"cannot connect to the Dask scheduler at {limits.show(scheduler)}: "
                                     f"clrender connects over tcp:// only, not {limits.show(scheme + '://')}")
    _check_greeting(scheduler, host, port, timeout)
    try:
        return dask_distributed.Client(scheduler, timeout=timeout)
    except Exception as e:   # OSError, TimeoutError, or what Dask makes of a peer it misreads
        raise DistributedRenderError(f"cannot connect to the Dask scheduler at {scheduler}: "
                                     f"{type(e).__name__}: {e}") from None


def _check_greeting(scheduler, host, port, timeout):
    """Raise DistributedRenderError unless HOST:PORT accepts a connection and sends what a Dask
    scheduler sends first, its handshake (a frame, length first, holding a dict with its pickle
    protocol), within `timeout` seconds in all. Dask's own connect waits forever for a peer that
    accepts and says nothing or stops half-way, and reads a web server's 'HTTP/1.1 400' as the
    length of a 3 EiB frame."""
    import msgpack   # Dask's wire format
    from distributed.protocol.utils import unpack_frames

    def fail(problem):
        return DistributedRenderError(f"cannot connect to the Dask scheduler at {scheduler}: {problem}")

    deadline = time.monotonic() + timeout
    try:
        with socket.create_connection((host or "127.0.0.1", port), timeout=timeout) as connection:
            def receive(count):
                data = b""
                while len(data) < count:
                    connection.settimeout(max(deadline - time.monotonic(), 1e-3))
                    received = connection.recv(min(count - len(data), 1 << 16))
                    if not received:
                        raise fail("it closed the connection during the Dask handshake")
                    data += received
                return data

            (length,) = struct.unpack("<Q", receive(8))
            if not 0 < length <= MAX_HANDSHAKE_BYTES:
                raise fail("what it sends is not a Dask handshake (a web server?)")
            frames, _ = unpack_frames(receive(length), partial=True)
            greeting = msgpack.loads(frames[0], use_list=False, strict_map_key=False)
    except socket.timeout:
        raise fail(f"no Dask handshake within {timeout:g} s (not a Dask scheduler, or a firewall?)") from None
    except OSError as e:
        raise fail(e.strerror or str(e)) from None
    except ClrenderError:
        raise
    except Exception:   # frames or msgpack that do not parse
        raise fail("what it sends is not a Dask handshake") from None
    if not (isinstance(greeting, dict) and "pickle-protocol" in greeting):
        raise fail("what it sends is not a Dask handshake")


def dask_setup(worker):
    """Dask's preload hook, run as each worker of `dask_client`'s LocalCluster starts (restarts
    too): Ctrl-C in the terminal, and SIGHUP when the terminal closes, reach these processes as
    well; they ignore them, and the client cancels their chunks and writes what it has. (SIGTERM
    stays: it is how the nanny stops a worker.)"""
    for signum in (signal.SIGINT, signal.SIGHUP):
        signal.signal(signum, signal.SIG_IGN)


def horizontal_strips(width, height, count):
    """About `count` strips (x, y, width, rows) covering the image top to bottom, all of the same
    rows but the last: PoCL compiles the kernel once per launch shape."""
    rows = math.ceil(height / max(1, min(int(count), height)))
    return [(0, top, width, min(rows, height - top)) for top in range(0, height, rows)]


def merge_strips(scene, states):
    """The whole-image Accumulation of the strips' Accumulations (top to bottom): laid side by
    side, never added, but for the light paths' fixed-point sums over the whole image, which are
    (exactly: integers). A strip without its aux buffers yet (no chunk done) reads as escaped rays."""
    width, height = scene.camera.resolution
    geometry = [s.geometry if s.geometry is not None else np.zeros((len(s.sums), 4), np.float32)
                for s in states]
    object_id = [s.object_id if s.object_id is not None else np.full(len(s.sums), -1, np.int32)
                 for s in states]
    aov_sums = None if states[0].aov_sums is None else np.concatenate([s.aov_sums for s in states])
    filtered = [s.filtered if s.filtered is not None else np.zeros((len(s.sums), 4), np.float32) for s in states]
    splatted = any(s.filtered is not None for s in states)
    lights = [s.light for s in states if s.light is not None]
    return Accumulation((0, 0, width, height), min(s.samples for s in states),
                        np.concatenate([s.sums for s in states]), sum(s.discarded for s in states),
                        sum(s.seconds for s in states), np.concatenate(geometry),
                        np.concatenate(object_id), aov_sums, np.concatenate(filtered) if splatted else None,
                        sum(lights[1:], lights[0]) if lights else None, sum(s.light_paths for s in states))


class _Chunk(NamedTuple):
    """A chunk in flight: its job, strip, future and the scattered scene it was given."""
    job: "_Job"
    tile: int
    future: object
    scene: object


class _Job:
    """A scene in flight: its scattered copy (scattered again `scatters` times) and the latest
    Accumulation of each strip."""

    def __init__(self, index, scene, scene_future, spp, strips, aovs=(), denoising=None):
        self.index, self.scene, self.scene_future, self.spp = index, scene, scene_future, spp
        self.scatters = 0
        self.aovs, self.denoising = aovs, denoising
        self.states = [Accumulation.start(strip, needs_sample_aovs(aovs)) for strip in strips]
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
        result = image_result(self.scene, merge_strips(self.scene, self.states), self.aovs, self.denoising)
        result.seconds = time.perf_counter() - self.started
        return result


def require_dask(where="distributed"):
    """The `distributed` package, or a MissingDependency naming `where` (e.g. the CLI flag) and
    saying how to install it."""
    try:
        import distributed
    except ImportError:
        raise MissingDependency(where, "distributed rendering needs Dask: pip install 'clrender[distributed]' "
                                       "(or 'dask[distributed]')") from None
    return distributed


def _chunk_results(finished, running, timeout, client):
    """(future, result) of each chunk as it finishes or is cancelled by the cluster (its scene
    lost with the workers holding it); a chunk's failure, or no chunk finishing for `timeout`
    seconds (of those `running()` returns), as DistributedRenderError."""
    from distributed import wait

    try:
        while True:
            if not finished.has_ready():
                pending = running()
                if pending:
                    try:
                        wait(pending, timeout=timeout, return_when="FIRST_COMPLETED")
                    except CancelledError:   # FuturesCancelledError: those futures come out of `finished`
                        pass
            yield next(finished)
    except StopIteration:
        return
    except ClrenderError:   # raised by the chunk itself on every try: already names the worker
        raise
    except TimeoutError:
        raise DistributedRenderError(f"no chunk finished within {timeout:g} s on the cluster of "
                                     f"{_scheduler_address(client)}") from None
    except Exception as e:   # KilledWorker: every worker that ran the chunk died; a lost scheduler
        raise DistributedRenderError(f"chunk failed on the cluster of {_scheduler_address(client)}: "
                                     f"{type(e).__name__}: {e}") from None


def _raise_a_failure(futures):
    """Raise the error of the first failed future, if any: the cause (a KilledWorker naming the
    worker) of a cancellation that reached the client first."""
    for future in futures:
        if future.status == "error":
            future.result()


@contextmanager
def _cluster_errors(client):
    """A failure of the cluster (a lost scheduler while scattering a scene) as DistributedRenderError."""
    try:
        yield
    except ClrenderError:
        raise
    except (OSError, TimeoutError) as e:
        raise DistributedRenderError(f"the cluster of {_scheduler_address(client)} failed: "
                                     f"{type(e).__name__}: {e}") from None


def _scheduler_address(client):
    return getattr(client.scheduler, "address", None) or "an unknown scheduler"


def _cancel(client, running):
    if running:
        client.cancel([chunk.future for chunk in running.values()])
        running.clear()


# ----- worker --------------------------------------------------------------------------------

_renderers = OrderedDict()   # per worker process: (scene key, options) -> Renderer, latest last
_contexts = {}               # device -> the cl.Context its renderers share (programs built once)
_device_lock = threading.Lock()
RENDERERS_KEPT = SCENES_IN_FLIGHT + 1


def _render_chunk(scene, scene_key, options, state, samples):
    """Dask task: add `samples` samples to the strip `state` on this worker's device. Returns
    (Accumulation, device description)."""
    try:
        with _device_lock:   # one chunk at a time on the device, however many threads
            renderer = _worker_renderer(scene, scene_key, *options[:5])
            result = renderer.accumulate(state, samples, *options[5:])
    except ClrenderError as e:   # the same error as a local render's, placed on its worker
        raise e.with_message(f"{_chunk_place(state, samples)}: {e.message}") from None
    except Exception as e:
        raise DistributedRenderError(f"{_chunk_place(state, samples)}: {type(e).__name__}: {e}") from None
    device = renderer.device
    return result, f"{device.name.strip()} [{device.platform.name.strip()}, driver {device.driver_version}]"


def _chunk_place(state, samples):
    """Where a chunk ran, for messages: the worker, the strip's rows, the samples."""
    _, y, _, rows = state.tile
    return (f"worker {_worker_address()}: rows {y}..{y + rows - 1}, samples {state.samples}.."
            f"{state.samples + samples - 1}")


def _worker_renderer(scene, scene_key, device, volume_method, step, raymarch_multiple_scattering, sampler):
    """This process's Renderer of the scattered scene `scene_key`, built on first use."""
    from .device import choose_device
    from .render import Renderer

    key = (scene_key, device, volume_method, step, raymarch_multiple_scattering, sampler)
    renderer = _renderers.pop(key, None)
    if renderer is None:
        cl_device = choose_device(device)
        context = _contexts.get(cl_device.int_ptr)
        renderer = Renderer(scene, cl_device, volume_method=volume_method, step=step,
                            raymarch_multiple_scattering=raymarch_multiple_scattering, context=context,
                            sampler=sampler)
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
