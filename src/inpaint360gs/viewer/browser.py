"""Headless Chromium driven over its DevTools protocol: screenshots of the viewer's page as the
browser draws it (software WebGL), for the page's test and ``benchmarks/bench_viewer.py``. Needs
Debian's ``chromium``; ``websockets`` comes with viser."""

from __future__ import annotations

import base64
import io
import json
import shutil
import socket
import subprocess
import time
import urllib.request

import numpy as np


def chromium() -> str | None:
    """The Chromium executable on the PATH, or None."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Browser:
    """Headless Chromium with one page, driven over the DevTools protocol (its websocket); ``proc`` is
    None where there is no Chromium. Screenshots are (H, W, 3) int16 RGB."""

    def __init__(self, size=(1280, 800)):
        from websockets.sync.client import connect

        exe = chromium()
        self.proc = None
        if exe is None:
            return
        port = free_port()
        flags = ["headless=new", "no-sandbox", "use-angle=swiftshader", "enable-unsafe-swiftshader", f"window-size={size[0]},{size[1]}", f"remote-debugging-port={port}"]
        self.proc = subprocess.Popen([exe, *("--" + f for f in flags), "about:blank"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        for _ in range(200):
            try:
                pages = json.loads(urllib.request.urlopen(f"http://127.0.0.1:{port}/json", timeout=1).read())
                url = next(p["webSocketDebuggerUrl"] for p in pages if p.get("type") == "page")
                break
            except (OSError, StopIteration, ValueError):
                time.sleep(0.1)
        else:
            self.close()
            raise RuntimeError("chromium's DevTools did not answer")
        self.ws = connect(url, max_size=None)
        self.n = 0

    def call(self, method: str, **params):
        self.n += 1
        self.ws.send(json.dumps({"id": self.n, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("id") == self.n:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg.get("result", {})

    def screenshot(self) -> np.ndarray:
        from PIL import Image

        for _ in range(50):  # right after a navigation the page may not be ready for a capture yet
            try:
                data = base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])
                break
            except RuntimeError:
                time.sleep(0.1)
        return np.asarray(Image.open(io.BytesIO(data)).convert("RGB")).astype(np.int16)

    def wait_for(self, test, timeout: float = 120.0) -> np.ndarray | None:
        """Screenshots every 0.1 s until ``test(image)`` holds (that image), or None after ``timeout`` s."""
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < timeout:
            img = self.screenshot()
            if test(img):
                return img
            time.sleep(0.1)
        return None

    def close(self) -> None:
        if getattr(self, "ws", None) is not None:
            self.ws.close()
        if self.proc is not None:
            self.proc.terminate()
            self.proc.wait()
