"""The viewer's web server (aiohttp): one page, its two static files, one WebSocket.

Every path starts with a random token (`/TOKEN/`); any request without it gets 403. The page can
ask for nothing but frames, camera moves and the save action, whose paths the server fixed at
start. The protocol, over the WebSocket at /TOKEN/socket:
  server -> page  text   {"type": "hello", ...} once: layers, tone maps, size, paths
                  binary a frame (frames.py) after each pass, of the layer this page shows;
                         only the latest: a slow page skips frames, it never queues them
                  text   {"type": "saved", "paths": [...]}, {"type": "error", "message": ...}
  page -> server  text   {"type": "layer", "layer": NAME}; a camera move (camera.move:
                         orbit, pan, zoom, reset); {"type": "save", "layer", "exposure", "tonemap"};
                         {"type": "stop"}: stop rendering and serving
When the last page closes, the server stops after `close_grace` seconds without a new one (a
reload reconnects within them).
"""
import asyncio
import concurrent.futures
import json
import secrets
from importlib import resources

from aiohttp import WSMsgType, web

from .. import limits
from ..errors import ArgumentError, ClrenderError
from .camera import MOVES
from .frames import Views, layer_names
from .output import save_view
from .tonemap import TONE_MAPS

STATIC = {"": ("index.html", "text/html"), "viewer.js": ("viewer.js", "text/javascript"),
          "viewer.css": ("viewer.css", "text/css")}
HEADERS = {"Cache-Control": "no-store", "Referrer-Policy": "no-referrer", "X-Content-Type-Options": "nosniff",
           "Content-Security-Policy": "default-src 'self'; img-src 'self' data:"}
MAX_MESSAGE_BYTES = 1 << 16   # page messages are small JSON objects


class Page:
    """One connected page: the layer it shows, the frame it was sent last."""

    def __init__(self, socket):
        self.socket = socket
        self.layer = "image"
        self.sent = None
        self.wake = asyncio.Event()


class ViewServer:
    """Serves `session` (a RenderSession) at http://host:port/TOKEN/ until `stop`."""

    def __init__(self, session, paths, denoiser, title, host="127.0.0.1", port=0, close_grace=2.0):
        self.session, self.paths, self.denoiser, self.title = session, paths, denoiser, title
        self.host, self.port, self.close_grace = host, port, close_grace
        self.token = secrets.token_urlsafe(32)
        self.url = None
        self.layers = layer_names(denoiser)
        self.pages = set()
        self._views = None
        self._loop = None
        self._stopped = None
        self._close_timer = None
        # Frames are made and files written off the event loop, one at a time.
        self._worker = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="clrender-view-frames")

    async def run(self, ready):
        """Serve until stopped; `ready(url)` once listening, `ready(error)` if it cannot listen."""
        self._loop = asyncio.get_running_loop()
        self._stopped = asyncio.Event()
        runner = web.AppRunner(self._application(), handle_signals=False, access_log=None)
        await runner.setup()
        try:
            site = web.TCPSite(runner, self.host, self.port)
            await site.start()
        except OSError as e:
            await runner.cleanup()
            ready(ArgumentError("port", f"cannot listen on {self.host}:{self.port}: {e.strerror or e}"))
            return
        port = runner.addresses[0][1]
        shown = f"[{self.host}]" if ":" in self.host else self.host
        self.url = f"http://{shown}:{port}/{self.token}/"
        ready(self.url)
        try:
            await self._stopped.wait()
        finally:
            await self._loop.run_in_executor(None, self.session.stop)
            for page in list(self.pages):
                await page.socket.close(message=b"viewer stopped")
            await runner.cleanup()
            self._worker.shutdown(wait=True)

    def stop(self):
        """Stop serving (from the server's thread: call it through loop.call_soon_threadsafe)."""
        if self._stopped is not None:
            self._stopped.set()

    def notify(self):
        """The session's listener: called from its thread after a pass, an error or its end."""
        self._call(self._changed)

    def request_stop(self):
        """`stop`, from any thread."""
        self._call(self.stop)

    def _call(self, function):
        try:
            self._loop.call_soon_threadsafe(function)
        except RuntimeError:   # the loop has closed: nothing left to do
            pass

    def _application(self):
        app = web.Application(middlewares=[self._check_token], client_max_size=MAX_MESSAGE_BYTES)
        prefix = f"/{self.token}"
        app.router.add_get(prefix, self._redirect)
        for name, (filename, content_type) in STATIC.items():
            app.router.add_get(f"{prefix}/{name}", self._static(filename, content_type))
        app.router.add_get(f"{prefix}/socket", self._socket)
        app.on_response_prepare.append(self._add_headers)
        return app

    @web.middleware
    async def _check_token(self, request, handler):
        first = request.rel_url.raw_path.lstrip("/").partition("/")[0]
        if not secrets.compare_digest(first.encode(), self.token.encode()):
            raise web.HTTPForbidden(text="clrender view: open the URL the viewer printed (it holds the access token)\n")
        return await handler(request)

    @staticmethod
    async def _add_headers(request, response):
        response.headers.update(HEADERS)

    async def _redirect(self, request):
        raise web.HTTPFound(f"/{self.token}/")

    @staticmethod
    def _static(filename, content_type):
        body = resources.files(__package__).joinpath("static", filename).read_bytes()

        async def serve(request):
            return web.Response(body=body, content_type=content_type, charset="utf-8")
        return serve

    async def _socket(self, request):
        socket = web.WebSocketResponse(compress=False, max_msg_size=MAX_MESSAGE_BYTES, heartbeat=20.0)
        await socket.prepare(request)
        page = Page(socket)
        self.pages.add(page)
        if self._close_timer is not None:
            self._close_timer.cancel()
            self._close_timer = None
        sender = asyncio.create_task(self._send_frames(page))
        try:
            await socket.send_json(self._hello())
            page.wake.set()
            async for message in socket:
                if message.type == WSMsgType.TEXT:
                    await self._handle(page, message.data)
        finally:
            sender.cancel()
            self.pages.discard(page)
            if not self.pages and not self._stopped.is_set():
                self._close_timer = self._loop.call_later(self.close_grace, self._stop_if_alone)
        return socket

    def _hello(self):
        width, height = self.session.home.resolution
        return {"type": "hello", "width": width, "height": height, "layers": list(self.layers),
                "tonemaps": list(TONE_MAPS), "target": self.session.target, "paths": [str(p) for p in self.paths],
                "scene": self.title}

    def _stop_if_alone(self):
        if not self.pages:
            self.stop()

    def _changed(self):
        snapshot = self.session.latest
        if snapshot is not None and (self._views is None or self._views.snapshot is not snapshot):
            self._views = Views(snapshot)
        for page in self.pages:
            page.wake.set()
        if self.session.error is not None:
            for page in self.pages:
                self._loop.create_task(_send_error(page, self.session.error))
            self.stop()

    async def _send_frames(self, page):
        """Send the page the latest frame of its layer whenever there is a newer one."""
        while True:
            await page.wake.wait()
            page.wake.clear()
            views, layer = self._views, page.layer
            if views is None or page.sent == (views, layer):
                continue
            page.sent = (views, layer)
            try:
                message = await self._loop.run_in_executor(self._worker, views.message, layer)
            except ClrenderError as e:   # e.g. Open Image Denoise failing: said on the page, which goes on
                await _send_error(page, e)
                continue
            if not await _send(page.socket.send_bytes, message):
                return

    async def _handle(self, page, text):
        """One message of the page; a bad one is answered with an error, never fatal."""
        try:
            message = json.loads(text)
            if not isinstance(message, dict):
                raise ArgumentError("message", f"expected a JSON object, got {limits.show(message)}")
            kind = message.get("type")
            if kind == "layer":
                page.layer = self._layer(message)
                page.wake.set()
            elif kind == "stop":
                self.stop()
            elif kind == "save":
                await self._save(page, message)
            elif kind in MOVES:
                self.session.move(message)
            else:
                raise ArgumentError("type", f"unknown message {limits.show(kind)}; valid: layer, save, stop, "
                                            + ", ".join(MOVES))
        except (ValueError, ClrenderError) as e:   # json's errors, ArgumentError, a file not written
            await _send_error(page, e)

    def _layer(self, message):
        layer = message.get("layer")
        if layer not in self.layers:
            raise ArgumentError("layer", f"unknown layer {limits.show(layer)}; valid: {', '.join(self.layers)}")
        return layer

    async def _save(self, page, message):
        curve = message.get("tonemap")
        if curve not in TONE_MAPS:
            raise ArgumentError("tonemap", f"unknown tone map {limits.show(curve)}; valid: {', '.join(TONE_MAPS)}")
        layer, exposure = self._layer(message), limits.setting("exposure", message.get("exposure"))
        views = self._views
        if views is None:
            raise ArgumentError("save", "nothing rendered yet")
        paths = await self._loop.run_in_executor(self._worker, save_view, views, self.paths, layer, exposure,
                                                 curve, self.denoiser)
        await _send(page.socket.send_json, {"type": "saved", "paths": paths, "samples": views.snapshot.state.samples})


async def _send(send, data):
    """send(data) on a page's socket; False if the page has gone meanwhile."""
    try:
        await send(data)
    except ConnectionError:
        return False
    return True


async def _send_error(page, error):
    await _send(page.socket.send_json, {"type": "error", "message": str(error)})

