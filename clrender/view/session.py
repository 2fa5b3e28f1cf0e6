"""The viewer's render loop: one render at a time of one scene, in a thread of its own.

The scene stays on the device (a Renderer). The loop adds passes of samples to an Accumulation
and publishes a Snapshot after each; a camera move cancels the pass in flight between two
launches (the progress callback of Renderer.accumulate raises) and starts again from no samples
with the new camera: only the RenderParams change (Renderer.set_camera). The first pass after a
start or a move is one sample (a frame at once); later passes are sized to about
`frame_seconds` of kernel time from the rate measured so far. Each pass continues the sums of the
last, so the snapshot after n samples holds exactly the image of a render of n samples.
"""
import threading
import time
from dataclasses import dataclass

from .. import limits
from ..device import device_errors
from ..render import Accumulation
from ..scene import Scene
from .camera import move


class PassCancelled(Exception):
    """Raised between two launches when the camera moved or the session stops."""


@dataclass(frozen=True)
class Snapshot:
    generation: int        # camera moves before this render: frames of an older one are stale
    scene: Scene           # the scene with the camera rendered
    state: Accumulation    # its sums after state.samples samples (never changed afterwards)
    target: int            # samples per pixel this render goes to
    seconds: float         # wall time since it started


class RenderSession:
    """Renders `renderer`'s scene to `spp` samples per pixel (default: the scene's) in a thread,
    again after each camera move. `listener()` (settable until `start`) is called from that
    thread after each snapshot, after an error (in `error`) and when the loop ends."""

    def __init__(self, renderer, spp=None, frame_seconds=0.3, listener=None):
        self.renderer = renderer
        self.target = limits.setting("spp", spp if spp is not None else renderer.scene.render.spp)
        self.frame_seconds = limits.number(frame_seconds, "frame_seconds", low=0.0, low_open=True)
        self.home = renderer.scene.camera
        self.error = None
        self.listener = listener or (lambda: None)
        self._lock = threading.Lock()
        self._camera, self._generation = self.home, 0
        self._latest = None
        self._wake = threading.Event()
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._run, name="clrender-view-render", daemon=True)

    @property
    def latest(self):
        """The Snapshot of the last pass completed, or None before the first."""
        return self._latest

    @property
    def finished(self):
        """Whether the loop has ended or is ending (stop, or an error in `error`)."""
        return self._stopping.is_set()

    @property
    def camera(self):
        """The camera asked for last (rendered from the next pass on)."""
        return self._camera

    def start(self):
        self._thread.start()
        return self

    def move(self, message):
        """Apply a camera message of the page (camera.move; ArgumentError for a bad one): the
        pass in flight is cancelled and the render starts again from the new camera."""
        with self._lock:
            self._camera = move(self._camera, self.home, message)
            self._generation += 1
        self._wake.set()

    def stop(self):
        """End the loop (the launch in flight finishes first) and let go of the renderer, so the
        device's buffers are freed."""
        self._stopping.set()
        self._wake.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join()
        self.renderer = None

    def _run(self):
        try:
            with device_errors():
                self._render_until_stopped()
        except Exception as error:   # reported to the page and raised again by the viewer's owner
            self.error = error
        finally:
            self._stopping.set()
            self.listener()

    def _render_until_stopped(self):
        rendered, state, count, started = None, None, 1, 0.0
        while not self._stopping.is_set():
            self._wake.clear()   # before reading the request: a move after this sets it again
            with self._lock:
                generation, camera = self._generation, self._camera
            if generation != rendered:
                self.renderer.set_camera(camera)
                width, height = camera.resolution
                state, count, started = Accumulation.start((0, 0, width, height), sample_aovs=True), 1, time.perf_counter()
                rendered = generation
            if state.samples >= self.target:
                self._wake.wait()
                continue
            try:
                state = self.renderer.accumulate(state, min(count, self.target - state.samples),
                                                 progress=self._cancel_unless(generation))
            except PassCancelled:
                continue
            self._latest = Snapshot(generation, self.renderer.scene, state, self.target, time.perf_counter() - started)
            self.listener()
            count = self._next_pass(state, count)

    def _cancel_unless(self, generation):
        """A progress callback stopping the pass when the camera moves on or the session stops."""
        def progress(done, end, seconds):
            if self._generation != generation or self._stopping.is_set():
                raise PassCancelled()
        return progress

    def _next_pass(self, state, count):
        """Samples of the next pass: about frame_seconds at the rate so far, at most 4x the last."""
        if state.seconds <= 0:
            return 2 * count
        return max(1, min(4 * count, int(self.frame_seconds * state.samples / state.seconds)))
