"""The viewer's server-side logic without a browser (clrender/view/): camera moves, tone maps,
frame encoding, the noise estimate, the render session (determinism, cancellation, nothing but
the camera uploaded again), the server's token and protocol, the save action, Jupyter."""
import asyncio
import dataclasses
import gc
import json
import math
import signal
import socket
import subprocess
import sys
import threading
import time
import types
import urllib.error
import urllib.request
import weakref

import imageio.v3 as iio
import numpy as np
import pytest

import clrender
from clrender.arrays import build_scene_arrays
from clrender.image import ldr_layer, tonemap
from clrender.render import Accumulation
from clrender.view import camera as moves
from clrender.view.frames import Views, encode_frame, relative_noise
from clrender.view.notebook import iframe
from clrender.view.output import output_paths
from clrender.view.session import RenderSession
from clrender.view.tonemap import TONE_MAPS, tone_map
from conftest import TEST_DEVICE, camera
from view_helpers import CORNELL, REPO, cornell_box, decode_frame, rendered, start_command

aiohttp = pytest.importorskip("aiohttp")


# --- camera moves -----------------------------------------------------------------------------

def image_x(cam, point):
    """Where `point` appears across the image of `cam`, -1 (left edge) to 1 (right edge)."""
    forward, right, _ = cam.basis()
    d = np.asarray(point, float) - cam.position
    return (d @ right) / (right @ right) / (d @ forward)


def test_orbit_turns_about_the_up_axis_at_the_same_distance():
    home = cornell_box().camera
    turned = moves.orbit(home, yaw=0.4, pitch=0.0)
    np.testing.assert_allclose(turned.look_at, home.look_at)
    offsets = [c.position - c.look_at for c in (home, turned)]
    np.testing.assert_allclose(*(np.linalg.norm(o) for o in offsets))
    assert offsets[1][1] == pytest.approx(offsets[0][1])   # same height: a turn about +y
    angle = math.atan2(offsets[1][0], offsets[1][2]) - math.atan2(offsets[0][0], offsets[0][2])
    assert angle == pytest.approx(0.4)                     # counter-clockwise seen from above
    raised = moves.orbit(home, 0.0, 0.3)
    elevation = math.asin((raised.position - raised.look_at)[1] / np.linalg.norm(raised.position - raised.look_at))
    assert elevation == pytest.approx(0.3)


def test_orbit_stops_short_of_the_pole():
    over = moves.orbit(cornell_box().camera, 0.0, 3.0)
    direction = (over.position - over.look_at) / np.linalg.norm(over.position - over.look_at)
    assert math.degrees(math.asin(direction[1])) == pytest.approx(90 - moves.POLE_MARGIN_DEGREES)
    assert np.all(np.isfinite(np.concatenate(over.basis())))


def test_pan_moves_the_target_with_the_pointer():
    home = cornell_box().camera
    panned = moves.pan(home, dx=0.1, dy=0.0)
    np.testing.assert_allclose(panned.position - home.position, panned.look_at - home.look_at)
    # The old target, 0.1 image widths right of the centre: 0.2 in [-1, 1] image coordinates.
    assert image_x(panned, home.look_at) == pytest.approx(0.2)


def test_zoom_scales_the_distance_within_bounds_and_reset_returns_home():
    home = cornell_box().camera
    distance = np.linalg.norm(home.position - home.look_at)
    closer = moves.move(home, home, {"type": "zoom", "factor": 0.5})
    assert np.linalg.norm(closer.position - closer.look_at) == pytest.approx(distance / 2)
    far = home
    for _ in range(3):
        far = moves.move(far, home, {"type": "zoom", "factor": 100})
    assert np.linalg.norm(far.position - far.look_at) == pytest.approx(distance * moves.DOLLY_RANGE[1])
    assert moves.move(far, home, {"type": "reset"}) is home


@pytest.mark.parametrize("message,where", [
    ({"type": "orbit", "yaw": "1", "pitch": 0}, "orbit.yaw"),
    ({"type": "orbit", "yaw": float("nan"), "pitch": 0}, "orbit.yaw"),
    ({"type": "pan", "dx": 0, "dy": 1e9}, "pan.dy"),
    ({"type": "zoom", "factor": 0}, "zoom.factor"),
    ({"type": "fly"}, "type"),
])
def test_bad_camera_messages_are_refused_by_name(message, where):
    home = cornell_box().camera
    with pytest.raises(clrender.ArgumentError) as error:
        moves.move(home, home, message)
    assert error.value.where == where


# --- tone maps, frames, noise -----------------------------------------------------------------

def test_clamp_is_the_render_commands_tone_map_and_the_curves_stay_in_range():
    rng = np.random.default_rng(0)
    image = (rng.lognormal(-1, 2, (16, 16, 3))).astype(np.float32)
    image[0, 0] = [np.nan, np.inf, -np.inf]
    for exposure in (-2.0, 0.0, 1.3):
        with np.errstate(over="ignore"):   # image.tonemap's -inf
            np.testing.assert_array_equal(tone_map(image, exposure, "clamp"), tonemap(image, exposure))
    ramp = np.geomspace(1e-4, 1e4, 300, dtype=np.float32)[None, :, None].repeat(3, axis=2)
    for curve in TONE_MAPS:
        values = tone_map(ramp, 0.0, curve)[0, :, 0].astype(int)
        assert np.all(np.diff(values) >= 0) and values[0] == 0, curve     # monotonic from black
    assert tone_map(ramp, 0.0, "reinhard")[0, -1, 0] == 255 and tone_map(ramp[:, :150], 0.0, "reinhard").max() < 255
    with pytest.raises(clrender.ArgumentError):
        tone_map(ramp, 0.0, "filmic")


@pytest.mark.parametrize("kind,pixels", [
    ("radiance", np.arange(2 * 3 * 3, dtype=np.float32).reshape(2, 3, 3) / 7),
    ("display", np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)),
])
def test_frames_decode_to_their_header_and_pixels(kind, pixels):
    for extra in range(4):   # every header length: the pixels start at a multiple of 4 bytes
        header = {"kind": kind, "width": 3, "height": 2, "layer": "x" * extra}
        message = encode_frame(header, pixels)
        (length,) = np.frombuffer(message[:4], "<u4")
        assert (4 + length) % 4 == 0
        decoded_header, decoded = decode_frame(message)
        assert decoded_header == header
        np.testing.assert_array_equal(decoded, pixels)


def test_relative_noise_of_known_variances():
    image = np.full((4, 4, 3), 2.0, np.float32)
    assert relative_noise(image, np.full_like(image, 0.04)) == pytest.approx(0.1)
    assert relative_noise(image, np.full_like(image, np.inf)) is None      # one sample: unknown
    assert relative_noise(np.zeros_like(image), np.zeros_like(image)) is None


def test_relative_noise_predicts_the_error_against_a_reference(device):
    # E|I - R|^2 per pixel = var(I) + var(R) for independent renders: the variance AOVs of both
    # predict the squared error; tolerance 5 standard errors of the per-pixel differences.
    # Independent samples: the AOV is the variance of a mean of iid samples (with Sobol's
    # stratified ones the true variance is lower, and the estimate an upper bound).
    scene = cornell_box(32, sampler="independent")
    noisy = rendered(scene, device, 16, seed=0)
    reference = rendered(scene, device, 512, seed=1)
    error = np.square(noisy.image.astype(np.float64) - reference.image).ravel()
    predicted = (noisy.aovs["variance"].astype(np.float64) + reference.aovs["variance"]).ravel()
    difference = error - predicted
    assert abs(difference.mean()) < 5 * difference.std(ddof=1) / math.sqrt(difference.size)
    estimate = relative_noise(noisy.image, noisy.aovs["variance"])
    measured = math.sqrt(max(error.sum() - reference.aovs["variance"].sum(), 0) / np.square(noisy.image).sum())
    assert 0.5 < estimate / measured < 2.0   # the same quantity, up to the noise of both sums


# --- the render session -----------------------------------------------------------------------

class Recorder:
    """A session listener keeping (generation, samples, time) of every snapshot."""

    def __init__(self):
        self.session = None
        self.seen = []
        self.changed = threading.Condition()

    def __call__(self):
        snapshot = self.session.latest
        with self.changed:
            if snapshot is not None and (not self.seen or self.seen[-1][2] is not snapshot):
                self.seen.append((snapshot.generation, snapshot.state.samples, snapshot, time.perf_counter()))
            self.changed.notify_all()

    def wait_for(self, test, timeout=60):
        with self.changed:
            assert self.changed.wait_for(lambda: any(test(*s[:2]) for s in self.seen) or self.session.finished,
                                         timeout), f"no such snapshot in {self.seen}"
        assert self.session.error is None, self.session.error
        return next(s for s in self.seen if test(*s[:2]))


def start_session(scene, device, spp, frame_seconds=0.3, pass_seconds=0.25):
    recorder = Recorder()
    session = RenderSession(clrender.Renderer(scene, device, pass_seconds=pass_seconds), spp, frame_seconds, recorder)
    recorder.session = session
    return session.start(), recorder


def test_snapshots_hold_exactly_the_render_of_their_samples(device):
    scene = cornell_box(32)
    session, recorder = start_session(scene, device, spp=24, frame_seconds=0.001)
    try:
        recorder.wait_for(lambda g, n: n == 24)
    finally:
        session.stop()
    counts = [n for _, n, _, _ in recorder.seen]
    assert counts[0] == 1 and counts == sorted(set(counts)) and len(counts) >= 3   # one sample, then passes
    renderer = clrender.Renderer(scene, device)
    for _, samples, snapshot, _ in recorder.seen[:3] + recorder.seen[-1:]:
        direct = renderer.accumulate(Accumulation.start(snapshot.state.tile, sample_aovs=True), samples)
        np.testing.assert_array_equal(snapshot.state.sums, direct.sums)
        np.testing.assert_array_equal(snapshot.state.aov_sums, direct.aov_sums)


def test_a_camera_move_cancels_the_pass_in_flight_and_uploads_only_the_camera(device):
    scene = cornell_box(128)
    # Launches of ~0.02 s, passes of up to 10 s: after 1 + 4 + 16 samples the pass in flight is
    # 64 samples, many launches long.
    session, recorder = start_session(scene, device, spp=10_000, frame_seconds=10.0, pass_seconds=0.02)
    renderer = session.renderer
    buffers = list(renderer._buffers)
    try:
        recorder.wait_for(lambda g, n: n == 21)
        moved_at = time.perf_counter()
        session.move({"type": "orbit", "yaw": 0.5, "pitch": 0.2})
        _, samples, first, shown_at = recorder.wait_for(lambda g, n: g == 1)
        pass_in_flight = 64 * recorder.seen[2][2].state.seconds / 21   # 64 samples at the rate so far
        assert [n for g, n, _, _ in recorder.seen if g == 0][-1] == 21    # it never completed
        assert samples == 1 and shown_at - moved_at < pass_in_flight / 2
    finally:
        session.stop()
    assert all(a is b for a, b in zip(renderer._buffers, buffers))   # the scene was not uploaded again
    expected = moves.orbit(scene.camera, 0.5, 0.2)
    np.testing.assert_allclose(first.scene.camera.position, expected.position)
    fresh = clrender.Renderer(dataclasses.replace(scene, camera=expected), device)
    direct = fresh.accumulate(Accumulation.start(first.state.tile, sample_aovs=True), 1)
    np.testing.assert_array_equal(first.state.sums, direct.sums)


def test_stopping_frees_the_renderer(device):
    session, recorder = start_session(cornell_box(16), device, spp=4)
    recorder.wait_for(lambda g, n: n == 4)
    renderer = weakref.ref(session.renderer)
    session.stop()
    gc.collect()
    assert renderer() is None and session.finished


def test_a_device_error_ends_the_session_and_is_kept(device):
    session, recorder = start_session(cornell_box(16), device, spp=4)

    def fail(*args, **kwargs):
        raise clrender.DeviceError("the device fell off")
    session.renderer.accumulate = fail
    session.move({"type": "reset"})
    with recorder.changed:
        assert recorder.changed.wait_for(lambda: session.finished, 30)
    assert isinstance(session.error, clrender.DeviceError)
    session.stop()


def test_set_camera_finds_the_medium_around_the_moved_camera(device):
    data = {"camera": camera(position=(0, 0, 5), resolution=(8, 8)),
            "media": [{"name": "fog", "sigma_a": 0.5}],
            "materials": [{"name": "boundary", "type": "interface"}],
            "shapes": [{"type": "sphere", "radius": 2.0, "material": "boundary", "interior": "fog"}],
            "lights": [{"type": "environment", "radiance": 1.0}]}
    scene = clrender.load_scene_dict(data)
    renderer = clrender.Renderer(scene, device)
    assert renderer.arrays.camera_medium == -1
    inside = dataclasses.replace(scene.camera, position=np.array([0.0, 0.3, 1.0]))
    renderer.set_camera(inside)
    assert renderer.arrays.camera_medium == 0 == build_scene_arrays(dataclasses.replace(scene, camera=inside)).camera_medium
    assert scene.camera.position[2] == 5   # the caller's scene is left as it was
    with pytest.raises(clrender.ArgumentError, match="resolution"):
        renderer.set_camera(dataclasses.replace(inside, resolution=(9, 8)))
    with pytest.raises(clrender.ArgumentError, match="span a view"):
        renderer.set_camera(dataclasses.replace(inside, look_at=inside.position.copy()))


# --- the server -------------------------------------------------------------------------------

@pytest.fixture
def viewer(tmp_path):
    viewer = clrender.view(cornell_box(16), spp=4, output=tmp_path / "saved.exr", device=TEST_DEVICE,
                           open_browser=False, block=False)
    yield viewer
    viewer.stop()


def status(url):
    try:
        with urllib.request.urlopen(url, timeout=10) as response:
            return response.status, dict(response.headers), response.read()
    except urllib.error.HTTPError as e:
        return e.code, dict(e.headers), e.read()


def test_every_request_without_the_token_is_forbidden(viewer):
    origin = viewer.url[:viewer.url.index(viewer.server.token)]
    for path in ("", "viewer.js", "socket", "x/", viewer.server.token[:-1] + "/", viewer.server.token.upper() + "/"):
        assert status(origin + path)[0] == 403, path
    code, headers, body = status(viewer.url)
    assert code == 200 and b"<canvas" in body and headers["Cache-Control"] == "no-store"
    assert "default-src 'self'" in headers["Content-Security-Policy"]
    assert status(viewer.url + "viewer.js")[0] == 200 and status(viewer.url + "nothing")[0] == 404
    assert status(viewer.url.rstrip("/"))[0] == 200   # redirected to the page

    async def open_socket(url):
        async with aiohttp.ClientSession() as session:
            async with session.ws_connect(url):
                pass
    with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
        asyncio.run(open_socket(origin + "socket"))
    assert refused.value.status == 403


async def talk(url, *messages, until=None):
    """Connect, send `messages`, and return the replies up to the first that `until` accepts
    (within 60 s)."""
    return await asyncio.wait_for(_talk(url, messages, until), 60)


async def _talk(url, messages, until):
    replies = []
    async with aiohttp.ClientSession() as session:
        async with session.ws_connect(url + "socket") as ws:
            replies.append(await ws.receive_json())
            for message in messages:
                await (ws.send_str(message) if isinstance(message, str) else ws.send_json(message))
            async for message in ws:
                reply = (decode_frame(message.data) if message.type == aiohttp.WSMsgType.BINARY
                         else json.loads(message.data))
                replies.append(reply)
                if until(reply):
                    return replies
    return replies


def is_frame(reply, **fields):
    return isinstance(reply, tuple) and all(reply[0][k] == v for k, v in fields.items())


def test_protocol_frames_layers_errors_and_save(viewer, tmp_path, device):
    hello, *_ = asyncio.run(talk(viewer.url, until=lambda r: is_frame(r, samples=4)))
    assert hello["type"] == "hello" and hello["width"] == 16 and "normal" in hello["layers"]
    assert hello["paths"] == [str(tmp_path / "saved.exr"), str(tmp_path / "saved.png")]
    replies = asyncio.run(talk(viewer.url, "{not json", {"type": "layer", "layer": "shadow"}, {"type": ["fly"]},
                               {"type": "layer", "layer": "normal"},
                               until=lambda r: is_frame(r, layer="normal")))
    errors = [r["message"] for r in replies if isinstance(r, dict) and r["type"] == "error"]
    assert len(errors) == 3 and "layer: unknown layer 'shadow'" in errors[1]
    assert errors[2].startswith("type: unknown message ['fly']; valid: layer, save, stop, orbit")
    header, pixels = replies[-1]
    expected = rendered(cornell_box(16), device, header["samples"])
    np.testing.assert_array_equal(pixels, ldr_layer("normal", expected.aovs["normal"]))
    save = {"type": "save", "layer": "image", "exposure": 1.0, "tonemap": "reinhard"}
    saved = asyncio.run(talk(viewer.url, save, until=lambda r: isinstance(r, dict) and r["type"] != "hello"))[-1]
    assert saved["type"] == "saved" and saved["samples"] == 4, saved
    layers = clrender.load_exr_layers(tmp_path / "saved.exr")
    final = rendered(cornell_box(16), device, 4)
    np.testing.assert_array_equal(layers[""], final.image)
    assert set(layers) >= {"", "albedo", "normal", "depth", "variance"}
    np.testing.assert_array_equal(iio.imread(tmp_path / "saved.png"), tone_map(final.image, 1.0, "reinhard"))


def test_the_denoised_layer_is_the_denoised_render(viewer, device):
    pytest.importorskip("pyoidn")
    replies = asyncio.run(talk(viewer.url, {"type": "layer", "layer": "denoised"},
                               until=lambda r: is_frame(r, layer="denoised", samples=4)))
    expected = clrender.Renderer(cornell_box(16), device).render(spp=4, denoise=True).image
    np.testing.assert_array_equal(replies[-1][1], expected)


def test_a_frame_that_cannot_be_made_is_an_error_on_the_page_which_goes_on(viewer, monkeypatch):
    layer = Views.layer

    def failing(self, name):
        if name == "albedo":
            raise clrender.DeviceError("Open Image Denoise failed: out of luck")
        return layer(self, name)
    monkeypatch.setattr(Views, "layer", failing)

    async def next_message(ws, kind):
        while (message := await ws.receive()).type != kind:
            pass
        return message

    async def switch():
        async with aiohttp.ClientSession() as session:
            async with session.ws_connect(viewer.url + "socket") as ws:
                await next_message(ws, aiohttp.WSMsgType.TEXT)   # hello
                await ws.send_json({"type": "layer", "layer": "albedo"})
                error = json.loads((await next_message(ws, aiohttp.WSMsgType.TEXT)).data)
                await ws.send_json({"type": "layer", "layer": "depth"})
                return error, decode_frame((await next_message(ws, aiohttp.WSMsgType.BINARY)).data)
    error, (header, _) = asyncio.run(asyncio.wait_for(switch(), 30))
    assert error == {"type": "error", "message": "Open Image Denoise failed: out of luck"}
    assert header["layer"] == "depth"


def test_the_last_page_closing_stops_the_viewer(tmp_path):
    viewer = clrender.view(cornell_box(16), spp=2, output=tmp_path / "v.exr", device=TEST_DEVICE,
                           open_browser=False, block=False)
    viewer.server.close_grace = 0.2
    asyncio.run(talk(viewer.url, until=lambda r: is_frame(r, samples=2)))
    start = time.perf_counter()
    viewer.wait()
    assert time.perf_counter() - start < 10 and not viewer.running and viewer.session.renderer is None


def test_a_port_in_use_is_an_argument_error(tmp_path):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        with pytest.raises(clrender.ArgumentError, match="cannot listen"):
            clrender.view(cornell_box(8), output=tmp_path / "v.exr", device=TEST_DEVICE,
                          port=taken.getsockname()[1], open_browser=False, block=False)


def test_output_paths(tmp_path):
    scene = clrender.load_scene(CORNELL)
    assert output_paths(None, scene) == (scene.path.with_suffix(".exr"), scene.path.with_suffix(".png"))
    assert output_paths(tmp_path / "a.png", scene) == (tmp_path / "a.exr", tmp_path / "a.png")
    assert output_paths(tmp_path / "b", cornell_box(8))[1] == tmp_path / "b.png"
    with pytest.raises(clrender.ArgumentError, match="--output"):
        output_paths(tmp_path / "c.gif", scene, "--output")


# --- Jupyter ----------------------------------------------------------------------------------

def test_the_iframe_shows_the_page():
    html = iframe('http://127.0.0.1:1/tok"en/', 256)
    assert 'src="http://127.0.0.1:1/tok&quot;en/"' in html and 'height="406"' in html


def test_in_a_notebook_view_returns_at_once_and_shows_the_page_inline(monkeypatch, tmp_path):
    kernel = types.SimpleNamespace(config={"IPKernelApp": {}})
    monkeypatch.setitem(sys.modules, "IPython", types.SimpleNamespace(get_ipython=lambda: kernel))
    opened = []
    monkeypatch.setattr("webbrowser.open", opened.append)
    viewer = clrender.view(cornell_box(8), spp=2, output=tmp_path / "v.exr", device=TEST_DEVICE)
    try:
        assert viewer.running and not opened
        assert f'src="{viewer.url}"' in viewer._repr_html_()
    finally:
        viewer.stop()   # what a notebook cell calls to end it
    assert not viewer.running and viewer.session.renderer is None


def test_without_aiohttp_the_viewer_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "aiohttp", None)
    with pytest.raises(clrender.MissingDependency, match=r"clrender\[view\]"):
        clrender.view(cornell_box(8), open_browser=False, block=False)


# --- the command ------------------------------------------------------------------------------

@pytest.mark.parametrize("args,code,message", [
    (["scenes/cornell_box.json", "--port", "70000"], 2, "--port: must be a port number"),
    (["scenes/cornell_box.json", "-o", "out.gif"], 2, "--output: the viewer saves .exr and .png"),
    (["scenes/missing.json"], 3, "scene file not found"),
    (["scenes/cornell_box.json", "-D", "spp=4"], 2, "-D: parameters apply to Mitsuba XML scenes only"),
])
def test_the_command_refuses_bad_arguments_before_serving(args, code, message):
    result = subprocess.run([sys.executable, "-m", "clrender.cli", "view", *args, "--no-browser"], cwd=REPO,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == code and message in result.stderr and "Traceback" not in result.stderr


def test_the_command_serves_a_mitsuba_scene_until_sigterm(tmp_path):
    command, url = start_command("scenes/cornell_box.xml", "-D", "resolution=24", "-o", str(tmp_path / "x"))
    try:
        hello, frame = asyncio.run(talk(url, until=lambda r: isinstance(r, tuple)))
        assert hello["scene"] == "cornell_box.xml" and hello["paths"][1] == str(tmp_path / "x.png")
        assert frame[1].shape == (24, 24, 3)
        command.send_signal(signal.SIGTERM)
        assert command.wait(30) == 128 + signal.SIGTERM
    finally:
        if command.poll() is None:
            command.kill()
    assert "Traceback" not in command.stderr.read()
