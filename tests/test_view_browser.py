"""The viewer's page in a real browser: headless Chromium driven by selenium (Debian's chromium
and chromium-driver; `.ci/run` installs them), on a 64 x 64 Cornell box. Skipped when either is
missing. What the page shows is read back from its canvas and compared with the images clrender
renders for the same camera and sample count."""
import base64
import dataclasses
import io
import math
import signal

import imageio.v3 as iio
import numpy as np
import pytest

import clrender
from clrender.image import ldr_layer
from clrender.view.tonemap import tone_map
from conftest import TEST_DEVICE
from view_helpers import CHROMEDRIVER, CHROMIUM, cornell_box, headless_chromium, rendered, start_command

pytest.importorskip("aiohttp")
pytest.importorskip("selenium.webdriver", reason="selenium is not installed (pip install -e '.[test]')")
from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.support.ui import Select, WebDriverWait  # noqa: E402

pytestmark = pytest.mark.skipif(not (CHROMIUM and CHROMEDRIVER),
                                reason="Chromium and its driver are not installed (apt-get install chromium chromium-driver)")
SIZE, SPP = 64, 64
# Frames captured as the page draws them: the frame's header and the canvas as a PNG.
CAPTURE = """
window.captured = [];
document.getElementById('image').addEventListener('frame', (e) =>
    window.captured.push({header: e.detail, png: e.target.toDataURL('image/png')}));
"""


@pytest.fixture(scope="module")
def browser():
    with headless_chromium() as driver:
        yield driver


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    return tmp_path_factory.mktemp("view")


@pytest.fixture(scope="module")
def viewer(outputs):
    viewer = clrender.view(cornell_box(SIZE), spp=SPP, output=outputs / "shot.exr", device=TEST_DEVICE,
                           open_browser=False, block=False)
    viewer.server.close_grace = 3600   # the tests load other pages between theirs
    yield viewer
    viewer.stop()


@pytest.fixture
def page(browser, viewer):
    """The page, freshly loaded, with the render restarted from the scene's camera (key R) and
    every frame drawn after that captured."""
    browser.get(viewer.url)
    wait(browser, lambda: browser.execute_script("return document.body.dataset.frames") is not None)
    browser.execute_script(CAPTURE)
    generation = viewer.session.latest.generation
    browser.find_element("tag name", "body").send_keys("r")
    wait(browser, lambda: any(f["header"]["generation"] > generation for f in captured(browser)))
    return browser


def wait(browser, condition, timeout=60):
    WebDriverWait(browser, timeout, poll_frequency=0.05).until(lambda _: condition())


def captured(browser):
    return browser.execute_script("return window.captured")


def decode(data_url):
    """The canvas's RGB pixels from a data: URL of a PNG."""
    return iio.imread(io.BytesIO(base64.b64decode(data_url.split(",", 1)[1])))[..., :3]


def canvas(browser):
    return decode(browser.execute_script("return document.getElementById('image').toDataURL('image/png')"))


def final_frame(browser, layer="image"):
    """The page's pixels once it shows the last frame of the current render in `layer`."""
    def shown():
        frames = [f for f in captured(browser) if f["header"]["layer"] == layer]
        return frames and frames[-1]["header"]["done"] and browser.execute_script(
            "return document.body.dataset.layer") == layer
    wait(browser, shown)
    return canvas(browser)


def assert_shows(pixels, expected):
    """The page's 8-bit pixels are those computed in Python: the page tone-maps float32 radiance
    in float64 steps rounded to float32, so a value on a rounding tie may come out one level off."""
    difference = np.abs(pixels.astype(int) - expected.astype(int))
    assert difference.max() <= 1 and np.mean(difference > 0) < 1e-3, (difference.max(), np.mean(difference > 0))


def frames_of_the_last_render(browser):
    frames = captured(browser)
    return [f for f in frames if f["header"]["generation"] == frames[-1]["header"]["generation"]]


def test_frames_converge_and_each_shows_the_render_of_its_samples(page, device):
    wait(page, lambda: len(frames_of_the_last_render(page)) >= 2)
    first, second = frames_of_the_last_render(page)[:2]
    (a, b) = (f["header"]["samples"] for f in (first, second))
    assert 0 < a < b, (a, b)
    shown = [decode(f["png"]).astype(float) for f in (first, second)]
    scene = cornell_box(SIZE)
    for frame, pixels in zip((first, second), shown):
        assert_shows(pixels.astype(np.uint8), tone_map(rendered(scene, device, frame["header"]["samples"]).image))
    assert np.mean(np.abs(shown[0] - shown[1])) > 1.0   # the two frames differ
    # Less noise against a reference of another seed: the squared errors of the second frame are
    # lower on average than the first's, by more than 5 standard errors of the paired differences.
    reference = tone_map(rendered(scene, device, 1024, seed=7).image).astype(float)
    gain = (np.square(shown[0] - reference) - np.square(shown[1] - reference)).ravel()
    assert gain.mean() > 5 * gain.std(ddof=1) / math.sqrt(gain.size), (a, b, gain.mean())


def test_dragging_orbits_the_camera_and_shows_the_new_view(page, viewer, device):
    before = final_frame(page)
    home = viewer.session.home
    generation = viewer.session.latest.generation
    image = page.find_element("id", "image")
    ActionChains(page).move_to_element(image).click_and_hold().move_by_offset(60, 20).release().perform()

    def rendered_the_last_move():
        latest, shown = viewer.session.latest, frames_of_the_last_render(page)[-1]["header"]
        return (latest.generation > generation and latest.scene.camera is viewer.session.camera
                and latest.state.samples == SPP and shown["generation"] == latest.generation and shown["done"])
    wait(page, rendered_the_last_move)
    moved = viewer.session.camera
    offsets = [c.position - c.look_at for c in (home, moved)]
    assert np.linalg.norm(offsets[0] - offsets[1]) > 0.1                            # it turned
    assert np.linalg.norm(offsets[1]) == pytest.approx(np.linalg.norm(offsets[0]))  # about the target
    after = final_frame(page)
    assert np.mean(np.abs(after.astype(float) - before)) > 10
    expected = rendered(dataclasses.replace(cornell_box(SIZE), camera=moved), device, SPP)
    assert_shows(after, tone_map(expected.image))


def test_the_exposure_slider_and_tone_maps_change_the_page_alone(page, device):
    generation = page.execute_script("return Number(document.body.dataset.generation)")
    image = rendered(cornell_box(SIZE), device, SPP).image
    assert_shows(final_frame(page), tone_map(image))
    slider = page.find_element("id", "exposure")
    page.execute_script("arguments[0].value = 1.5; arguments[0].dispatchEvent(new Event('input'))", slider)
    brighter = canvas(page)
    assert_shows(brighter, tone_map(image, 1.5))
    assert brighter.mean() > tone_map(image).mean() + 20
    for curve in ("reinhard", "aces"):
        Select(page.find_element("id", "tonemap")).select_by_value(curve)
        assert_shows(canvas(page), tone_map(image, 1.5, curve))
    # No new render: the page tone-maps the frame it has.
    assert page.execute_script("return Number(document.body.dataset.generation)") == generation


def test_the_layer_switch_shows_the_normal_buffer(page, device):
    final_frame(page)
    Select(page.find_element("id", "layer")).select_by_value("normal")
    normals = rendered(cornell_box(SIZE), device, SPP).aovs["normal"]
    np.testing.assert_array_equal(final_frame(page, "normal"), ldr_layer("normal", normals))


def test_save_writes_an_exr_with_layers_and_the_png_shown(page, viewer, outputs, device):
    final_frame(page)
    page.find_element("tag name", "body").send_keys("++")   # +1 stop
    page.find_element("tag name", "body").send_keys("s")
    wait(page, lambda: page.execute_script("return document.body.dataset.saved"))
    expected = rendered(cornell_box(SIZE), device, SPP)
    layers = clrender.load_exr_layers(outputs / "shot.exr")
    np.testing.assert_array_equal(layers[""], expected.image)
    for name in ("albedo", "normal", "variance"):
        np.testing.assert_array_equal(layers[name], expected.aovs[name])
    np.testing.assert_array_equal(layers["depth"][..., 0], expected.aovs["depth"])
    np.testing.assert_array_equal(iio.imread(outputs / "shot.png"), tone_map(expected.image, 1.0))


def test_the_notebook_output_shows_the_live_page(browser, viewer, tmp_path):
    # What Jupyter does with the Viewer a cell returns: its _repr_html_ in the output area.
    cell = tmp_path / "output.html"
    cell.write_text(f"<!doctype html><html><body>{viewer._repr_html_()}</body></html>")
    browser.get(cell.as_uri())
    browser.switch_to.frame(browser.find_element("tag name", "iframe"))
    try:
        wait(browser, lambda: browser.execute_script("return document.body.dataset.samples") == str(SPP))
        assert canvas(browser).shape == (SIZE, SIZE, 3)
    finally:
        browser.switch_to.default_content()


def test_a_request_without_the_token_gets_403(browser, viewer):
    origin = viewer.url[:viewer.url.index(viewer.server.token)]
    browser.get(origin)
    assert "access token" in browser.find_element("tag name", "body").text
    assert browser.execute_script("return performance.getEntriesByType('navigation')[0].responseStatus") == 403


def test_the_command_exits_cleanly_on_sigint(browser, tmp_path):
    command, url = start_command("scenes/cornell_box.json", "--spp", "100000", "-o", str(tmp_path / "out.exr"))
    try:
        browser.get(url)
        wait(browser, lambda: browser.execute_script("return document.body.dataset.frames") is not None)
        command.send_signal(signal.SIGINT)
        assert command.wait(30) == 130
    finally:
        if command.poll() is None:
            command.kill()
    stderr = command.stderr.read()
    assert "Traceback" not in stderr and "clrender: interrupted" in stderr
    wait(browser, lambda: browser.execute_script("return document.body.dataset.closed") == "1", timeout=10)
