"""The README's screenshot of the viewer's page (docs/images/viewer.png), taken in headless
Chromium (apt-get install chromium chromium-driver) once the render has converged.

    python tools/view_screenshot.py [--scene scenes/cornell_box.json] [--spp 256] [-o docs/images/viewer.png]

Paths are relative to the repository's root. Nothing is saved: the page only shows where its
save action would write.
"""
import argparse
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]
import clrender  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402
from view_helpers import headless_chromium  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="scenes/cornell_box.json")
    parser.add_argument("--spp", type=int, default=256)
    parser.add_argument("--device", default=None)
    parser.add_argument("-o", "--output", default="docs/images/viewer.png")
    args = parser.parse_args()
    os.chdir(ROOT)
    viewer = clrender.view(args.scene, spp=args.spp, device=args.device, open_browser=False, block=False)
    try:
        with headless_chromium(960, 620) as browser:   # the image at its own size, the tool bar on one line
            browser.get(viewer.url)
            WebDriverWait(browser, 300, poll_frequency=0.1).until(
                lambda b: b.execute_script("return document.body.dataset.samples") == str(args.spp))
            browser.save_screenshot(args.output)
    finally:
        viewer.stop()
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
