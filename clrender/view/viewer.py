"""A running viewer: the render session (its own thread) and the web server (a thread with its own
event loop), so that it runs beside a notebook kernel's loop as well as under a plain script."""
import asyncio
import os
import queue
import sys
import threading
import webbrowser

from ..denoise import check_denoiser
from ..errors import DenoiserUnavailable, MissingDependency
from ..render import Renderer
from ..scene import as_scene
from .frames import Views
from .notebook import in_notebook, iframe
from .output import output_paths
from .session import RenderSession


def _server_module():
    """clrender.view.server, or MissingDependency when aiohttp (the `view` extra) is missing."""
    try:
        import aiohttp  # noqa: F401
    except ImportError as e:
        raise MissingDependency("view", f"the viewer needs aiohttp: pip install 'clrender[view]' ({e})") from None
    from . import server
    return server


def _has_denoiser():
    try:
        check_denoiser()
    except DenoiserUnavailable:
        return False
    return True


class Viewer:
    """The live view of one scene at `url` (with its access token), from `start` until `stop`, the
    last page closing, or an error of the render (raised again by `wait`). Arguments: those of
    `view`; `close_grace`: seconds the server waits for a page after the last one closed."""

    def __init__(self, scene, spp=None, output=None, device=None, host="127.0.0.1", port=0,
                 frame_seconds=0.3, close_grace=2.0):
        server = _server_module()
        scene = as_scene(scene)
        paths = output_paths(output, scene)
        self.session = RenderSession(Renderer(scene, device), spp, frame_seconds)
        title = scene.path.name if scene.path is not None else "scene"
        self.server = server.ViewServer(self.session, paths, _has_denoiser(), title, host, port, close_grace)
        self.session.listener = self.server.notify
        self.height = scene.camera.resolution[1]
        self.url = None
        self._failure = None
        self._thread = None
        # Set when the server's thread ends. Waited on instead of joining the thread: a join that
        # Ctrl-C interrupts can leave Thread.is_alive() False for a thread still running
        # (CPython 3.11), and a daemon thread left in C++ code at exit aborts the process.
        self._ended = threading.Event()

    def start(self):
        """Listen (ArgumentError if the port cannot be had), then render; returns self."""
        ready = queue.Queue()
        self._thread = threading.Thread(target=self._serve, args=(ready,), name="clrender-view-server", daemon=True)
        self._thread.start()
        outcome = ready.get()
        if isinstance(outcome, Exception):
            self._thread.join()
            raise outcome
        self.url = outcome
        self.session.start()
        return self

    def _serve(self, ready):
        try:
            asyncio.run(self.server.run(ready.put))
        except Exception as error:   # a bug: raised again by wait(), or by start() before listening
            self._failure = error
            ready.put(error)
        finally:
            self._ended.set()

    @property
    def running(self):
        return self._thread is not None and not self._ended.is_set()

    def wait(self):
        """Block until the viewer stops; raise the render's error if that stopped it."""
        while self._thread is not None and not self._ended.wait(0.2):   # short waits: signals get through
            pass
        error = self.session.error or self._failure
        if error is not None:
            raise error

    def stop(self):
        """Stop rendering (the launch in flight finishes) and serving; the device is let go."""
        if self.running:
            self.server.request_stop()
            self._ended.wait()

    def result(self):
        """The RenderResult of the last pass (every AOV in result.aovs), or None before the first."""
        snapshot = self.session.latest
        return None if snapshot is None else Views(snapshot).result()

    def _repr_html_(self):   # Jupyter shows the page inline
        return iframe(self.url, self.height)

    def __repr__(self):
        return f"<clrender Viewer {'at ' + self.url if self.running else 'stopped'}>"


def view(scene, spp=None, output=None, device=None, host="127.0.0.1", port=0, open_browser=None, block=None,
         frame_seconds=0.3):
    """Show `scene` (a Scene, a scene dict or a JSON or Mitsuba XML file) converging in a web page
    and return its Viewer: the image after each pass, exposure and tone map, the AOVs, the
    denoised image (with pyoidn), camera orbit/pan/zoom with the mouse, save (docs/viewer.md).
    `spp`: samples per pixel to render to (default the scene's); `output`: the save action's
    EXR and PNG path (default: next to the scene file); `device` as for Renderer; `host`,
    `port`: where to listen (default 127.0.0.1, any free port); `frame_seconds`: kernel time
    per pass after the first. In a Jupyter notebook the Viewer shows the page inline and the
    call returns at once (`viewer.stop()` ends it); elsewhere it opens the browser and blocks
    until the last page closes or Ctrl-C (both stop the render and free the device)."""
    notebook = in_notebook()
    open_browser = not notebook if open_browser is None else open_browser
    block = not notebook if block is None else block
    viewer = Viewer(scene, spp, output, device, host, port, frame_seconds).start()
    if block:
        print(f"clrender: view at {viewer.url} (Ctrl-C to stop)", file=sys.stderr)
    if open_browser:
        open_page(viewer.url)
    if block:
        try:
            viewer.wait()
        except KeyboardInterrupt:
            viewer.stop()
            raise
    return viewer


def open_page(url):
    """Open `url` in the user's browser, in a thread of its own (a browser can take long to
    start). Not on a Linux machine without a display: there Python would run a text browser in
    the terminal."""
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        print("clrender: no display to open a browser on: open the URL above", file=sys.stderr)
        return
    threading.Thread(target=webbrowser.open, args=(url,), daemon=True).start()
