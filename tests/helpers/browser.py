"""A headless Chromium driven over the DevTools protocol: open a page, collect its console
errors, check its images, take a screenshot. For the docs' browser check (`test_docs.py`)."""

from __future__ import annotations

import base64
import functools
import http.server
import json
import shutil
import subprocess
import tempfile
import threading
import time
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

FLAGS = (
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--remote-debugging-port=0",
)  # fmt: skip
"""Headless, and nothing fetched from elsewhere (a closed network refuses it)."""
IMAGES = """[...document.images].map(i => ({src: i.getAttribute('src'), complete: i.complete,
    width: i.naturalWidth}))"""


BOX = """(() => {
    const a = document.querySelector(%s), b = document.querySelector(%s);
    if (!a || !b) return null;
    const top = a.getBoundingClientRect().top + scrollY - 16;
    const bottom = b.getBoundingClientRect().top + scrollY;
    const left = a.parentElement.getBoundingClientRect().left + scrollX - 16;
    return {x: Math.max(0, left), y: Math.max(0, top),
            width: Math.min(document.documentElement.clientWidth - left, 1100),
            height: Math.min(16000, bottom - top)};
})()"""
PAGE_BOX = """({x: 0, y: 0, width: document.documentElement.clientWidth,
    height: Math.min(16000, document.documentElement.scrollHeight)})"""


def chromium() -> str | None:
    """The Chromium executable (Debian's package `chromium`), or None."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


@contextmanager
def serve(folder: Path) -> Iterator[str]:
    """`folder` over HTTP on the loopback (an ephemeral port): its base URL."""
    handler = functools.partial(QuietHandler, directory=str(folder))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()


class QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args) -> None:
        pass


class Browser:
    """One headless Chromium with one page, driven by DevTools commands."""

    def __init__(self, executable: str, width: int = 1280, height: int = 900) -> None:
        import websocket

        self.profile = tempfile.TemporaryDirectory()
        self.width, self.height = width, height
        self.process = subprocess.Popen(
            [executable, *FLAGS, f"--user-data-dir={self.profile.name}",
             f"--window-size={width},{height}", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        try:
            port = self._port(Path(self.profile.name) / "DevToolsActivePort")
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as r:
                page = next(t for t in json.load(r) if t["type"] == "page")
            # no Origin header: Chromium refuses a DevTools socket from another origin
            self.socket = websocket.create_connection(
                page["webSocketDebuggerUrl"], timeout=30, suppress_origin=True
            )
        except BaseException:
            self._stop()
            raise
        self.next_id = 0
        self.events: list[dict] = []
        for domain in ("Page", "Runtime", "Log"):
            self.send(f"{domain}.enable")

    def _port(self, file: Path, timeout: float = 30.0) -> int:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if file.exists() and file.read_text().strip():
                return int(file.read_text().split()[0])
            if self.process.poll() is not None:
                raise RuntimeError(f"chromium exited: {self.process.stderr.read()[-2000:]}")
            time.sleep(0.1)
        raise TimeoutError("chromium did not open its DevTools port")

    def send(self, method: str, **params) -> dict:
        """Run a DevTools command and return its result; events that arrive meanwhile are
        kept in `events`."""
        self.next_id += 1
        self.socket.send(json.dumps({"id": self.next_id, "method": method, "params": params}))
        while True:
            message = json.loads(self.socket.recv())
            if message.get("id") == self.next_id:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message["result"]
            self.events.append(message)

    def wait_for(self, event: str, timeout: float = 30.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            message = json.loads(self.socket.recv())
            self.events.append(message)
            if message.get("method") == event:
                return
        raise TimeoutError(event)

    def open(self, url: str) -> None:
        """Load `url` and wait for its load event, then for its images."""
        self.events.clear()
        self.send("Page.navigate", url=url)
        self.wait_for("Page.loadEventFired")
        for _ in range(50):
            if all(image["complete"] for image in self.images()):
                break
            time.sleep(0.1)

    def evaluate(self, expression: str):
        result = self.send("Runtime.evaluate", expression=expression, returnByValue=True)
        return result["result"].get("value")

    def images(self) -> list[dict]:
        return self.evaluate(IMAGES)

    def errors(self) -> list[str]:
        """The console errors, uncaught exceptions and failed loads since the page opened."""
        found = []
        for event in self.events:
            method, params = event.get("method"), event.get("params", {})
            if method == "Runtime.exceptionThrown":
                found.append(params["exceptionDetails"].get("text", "exception"))
            elif method == "Runtime.consoleAPICalled" and params.get("type") == "error":
                found.append(" ".join(str(a.get("value", a)) for a in params.get("args", [])))
            elif method == "Log.entryAdded" and params["entry"]["level"] == "error":
                found.append(f"{params['entry']['text']} {params['entry'].get('url', '')}")
        return found

    def screenshot(
        self, path: Path, between: tuple[str, str] | None = None, full: bool = False
    ) -> None:
        """The viewport; with `between`, the page from the top of the first element one CSS
        selector matches to the top of the other's (a section); with `full`, the whole page
        (cut at 16,000 px)."""
        params: dict = {"format": "png"}
        if between is not None or full:
            box = self.evaluate(BOX % tuple(map(json.dumps, between)) if between else PAGE_BOX)
            if box is None:
                raise ValueError(f"no elements match {between}")
            params.update(captureBeyondViewport=True, clip={**box, "scale": 1})
        data = self.send("Page.captureScreenshot", **params)["data"]
        path.write_bytes(base64.b64decode(data))

    def close(self) -> None:
        try:
            self.socket.close()
        finally:
            self._stop()

    def _stop(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.profile.cleanup()
