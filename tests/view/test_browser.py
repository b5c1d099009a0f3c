"""``genie view --serve`` in a real browser: Rerun's web viewer hosted on the loopback address,
opened in headless Chromium (Debian's package; WebGL on SwiftShader), screenshotted until the
3-D view shows the scene's cloud in the classes' colours (not a blank page, not an error page)."""

import time

import pytest
from PIL import Image

from genie_gl.view import read_views, serve, write_rrd

from .browser import Browser, class_colour_pixels, classes_shown

pytestmark = pytest.mark.gl
WAIT_S = (
    240  # the viewer's wasm loads and SwiftShader draws on a busy CPU: seconds to a few minutes
)
ENOUGH = 3  # classes of the scene drawn in their colours (the test scene shows 4-5 of 1..9)


def test_the_web_view_shows_the_scene_in_headless_chromium(datasets, tmp_path):
    rrd = write_rrd(read_views(datasets["static"]), tmp_path / "v.rrd")
    served = serve(rrd, port=0, log_path=tmp_path / "rerun.log")
    try:
        assert served.url.startswith("http://127.0.0.1:")  # loopback unless told otherwise
        browser = Browser(served.url, tmp_path / "console.log", profile=tmp_path / "profile")
        try:
            seen, img = 0, None
            deadline = time.monotonic() + WAIT_S
            while time.monotonic() < deadline and seen < ENOUGH:
                time.sleep(5)
                img = browser.screenshot()
                seen = classes_shown(img)
            Image.fromarray(img).save(tmp_path / "view_web.png")
        finally:
            browser.close()
    finally:
        served.stop()
    console = (tmp_path / "console.log").read_text(errors="replace")
    assert "Wasm loaded" in console, console[-2000:]
    assert seen >= ENOUGH, (
        f"the 3-D view shows {seen} classes (pixels per class {class_colour_pixels(img)}); "
        f"console:\n{console[-3000:]}"
    )


def test_an_error_page_has_none_of_the_scenes_colours(tmp_path):
    """The measure above can fail: a browser pointed at a port nobody serves shows none."""
    from genie_gl.view.serve import free_port

    browser = Browser(
        f"http://127.0.0.1:{free_port('127.0.0.1')}/",
        tmp_path / "console.log",
        profile=tmp_path / "profile",
    )
    try:
        time.sleep(3)
        img = browser.screenshot()
    finally:
        browser.close()
    assert img.std() > 0 and classes_shown(img) < ENOUGH
