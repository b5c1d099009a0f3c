"""Headless Chromium (Debian's ``chromium``) driven over the DevTools protocol on a pipe
(``--remote-debugging-pipe``: JSON messages ending in NUL on fds 3 and 4), no driver package:
open a page, take screenshots, keep the console log."""

from __future__ import annotations

import base64
import io
import json
import os
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np

# WebGL on the CPU: SwiftShader through ANGLE (headless Chromium has no GPU here)
FLAGS = (
    "--headless=new",
    "--no-sandbox",
    "--use-gl=angle",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--ignore-gpu-blocklist",
    "--enable-webgl",
    "--no-first-run",
    "--no-default-browser-check",
    "--disable-extensions",
    "--enable-logging=stderr",
    "--v=0",
    "--remote-debugging-pipe",
)


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


class Browser:
    """One headless Chromium showing ``url`` in a ``width`` x ``height`` window; its console
    and errors go to ``log_path``."""

    def __init__(
        self,
        url: str,
        log_path: Path,
        *,
        width: int = 1280,
        height: int = 800,
        profile: Path | None = None,
    ) -> None:
        exe = chromium()
        if exe is None:
            raise RuntimeError(
                "chromium is not installed (apt-get install chromium; make setup does it)"
            )
        to_chrome_r, self._to_chrome = os.pipe()
        self._from_chrome, from_chrome_w = os.pipe()
        self._log = open(log_path, "wb")
        args = [exe, *FLAGS, f"--window-size={width},{height}"]
        if profile is not None:
            args.append(f"--user-data-dir={profile}")
        # fds 3 and 4 of the child: the protocol's pipe (dup2 in the child through pass_fds order)
        self.process = subprocess.Popen(
            args + [url],
            stdout=self._log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            pass_fds=(3, 4, to_chrome_r, from_chrome_w),
            preexec_fn=lambda: (os.dup2(to_chrome_r, 3), os.dup2(from_chrome_w, 4)),
        )
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        self._buf = b""
        self._id = 0
        targets = self.call("Target.getTargets")["targetInfos"]
        page = next(t for t in targets if t["type"] == "page")
        self.session = self.call("Target.attachToTarget", targetId=page["targetId"], flatten=True)[
            "sessionId"
        ]

    def call(self, method: str, session: str | None = None, timeout_s: float = 180.0, **params):
        self._id += 1
        msg = {"id": self._id, "method": method, "params": params}
        if session:
            msg["sessionId"] = session
        os.write(self._to_chrome, json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            while b"\0" in self._buf:
                raw, self._buf = self._buf.split(b"\0", 1)
                reply = json.loads(raw)
                if reply.get("id") == self._id:
                    if "error" in reply:
                        raise RuntimeError(f"{method}: {reply['error']}")
                    return reply["result"]
            chunk = os.read(self._from_chrome, 1 << 20)
            if not chunk:
                raise RuntimeError(
                    f"chromium closed the DevTools pipe (exit {self.process.poll()})"
                )
            self._buf += chunk
        raise TimeoutError(method)

    def screenshot(self) -> np.ndarray:
        """(H, W, 3) uint8 of the page now."""
        from PIL import Image

        data = self.call("Page.captureScreenshot", session=self.session, format="png")["data"]
        return np.asarray(Image.open(io.BytesIO(base64.b64decode(data))).convert("RGB"))

    def close(self) -> None:
        try:
            self.call("Browser.close", timeout_s=10)
        except (RuntimeError, TimeoutError, OSError):
            pass
        try:
            self.process.wait(10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        for fd in (self._to_chrome, self._from_chrome):
            try:
                os.close(fd)
            except OSError:
                pass
        self._log.close()


def class_colour_pixels(img: np.ndarray) -> np.ndarray:
    """(9,) pixels of the 3-D view (the viewport's left two thirds, below the top bar, above
    the time panel) within 60 (sum over channels) of class colour 1..9 of the label map: the
    scene's objects as the annotation context colours them. The viewer's own chrome is grey
    with few coloured accents; a page of one accent colour matches one class at most."""
    from genie_gl import labels

    h, w = img.shape[:2]
    view = img[int(0.08 * h) : int(0.72 * h), int(0.16 * w) : int(0.62 * w)].astype(int)
    colours = np.array([labels.color(k) for k in range(1, 10)])
    d = np.abs(view[:, :, None, :] - colours[None, None]).sum(-1)
    return (d < 60).sum((0, 1))


def classes_shown(img: np.ndarray, min_pixels: int = 100) -> int:
    """How many of the classes 1..9 the 3-D view shows with at least ``min_pixels`` pixels."""
    return int((class_colour_pixels(img) >= min_pixels).sum())
