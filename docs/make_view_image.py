"""The picture of ``genie view``'s web viewer (``make docs-view-image``): the demo dataset's
Rerun recording served on 127.0.0.1, opened in headless Chromium (the tests' driver,
``tests/view/browser.py``) and screenshotted once the 3-D view shows the scene's classes."""

import sys
import tempfile
import time
from pathlib import Path

from PIL import Image

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests" / "view"))
from browser import Browser, classes_shown  # noqa: E402

from genie_gl.view import read_views, serve, write_rrd  # noqa: E402

dataset = Path(sys.argv[1] if len(sys.argv) > 1 else "out/demo")
image = ROOT / "docs" / "images" / "view_web.png"
with tempfile.TemporaryDirectory() as tmp:
    tmp = Path(tmp)
    rrd = write_rrd(read_views(dataset), tmp / "view.rrd")
    served = serve(rrd, port=0, log_path=tmp / "rerun.log")
    try:
        browser = Browser(
            served.url, tmp / "console.log", width=1600, height=1000, profile=tmp / "profile"
        )
        try:
            img, seen, deadline = None, 0, time.monotonic() + 300
            while time.monotonic() < deadline and seen < 3:
                time.sleep(5)
                img = browser.screenshot()
                seen = classes_shown(img)
            time.sleep(5)  # let the last frame settle
            img = browser.screenshot()
        finally:
            browser.close()
    finally:
        served.stop()
    if classes_shown(img) < 3:
        sys.exit(f"the web view showed {classes_shown(img)} classes; see {tmp / 'console.log'}")
    Image.fromarray(img).save(image)
print(f"{image}: the web view of {dataset}")
