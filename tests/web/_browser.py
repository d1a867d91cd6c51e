"""Helpers for browser tests: Debian's Chromium through playwright, and the server as a process."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import urlencode

import numpy as np
import numpy.typing as npt
import pytest
from playwright.sync_api import Browser, ConsoleMessage, Page, sync_playwright

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
]
HEALTH_TIMEOUT_S = 30.0


def _wait_healthy(url: str, proc: subprocess.Popen[bytes], log: Path) -> None:
    """Poll ``GET /api/health`` until it answers (503 too: the server is up, no source is live)."""
    deadline = time.monotonic() + HEALTH_TIMEOUT_S
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            pytest.fail(f"server exited with {proc.returncode}:\n{log.read_text()}")
        try:
            with urllib.request.urlopen(f"{url}/api/health", timeout=2) as response:
                if response.status == 200:
                    return
        except urllib.error.HTTPError as error:
            if error.code in (401, 503):  # up: no token given, or no source live yet
                return
        except (urllib.error.URLError, ConnectionError, TimeoutError):
            pass
        time.sleep(0.2)
    pytest.fail(f"no 200 from {url}/api/health within {HEALTH_TIMEOUT_S} s:\n{log.read_text()}")


@contextmanager
def server_process(
    port: int, log: Path, *args: str, env: dict[str, str] | None = None
) -> Iterator[str]:
    """``python -m server`` on ``port`` (plus ``args``) until the block ends; yields its URL."""
    url = f"http://127.0.0.1:{port}"
    with log.open("ab") as out:
        proc = subprocess.Popen(
            [sys.executable, "-m", "server", "--host", "127.0.0.1", "--port", str(port), *args],
            cwd=ROOT,
            env=None if env is None else {**os.environ, **env},
            stdout=out,
            stderr=subprocess.STDOUT,
        )
        try:
            _wait_healthy(url, proc, log)
            yield url
        finally:
            _stop(proc)


@contextmanager
def chromium() -> Iterator[Browser]:
    """Debian's Chromium, headless, with software WebGL (SwiftShader)."""
    assert CHROMIUM.exists(), f"{CHROMIUM} is missing: apt-get install chromium"
    with sync_playwright() as pw:
        browser = pw.chromium.launch(
            executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_ARGS
        )
        try:
            yield browser
        finally:
            browser.close()


@dataclass
class Watched:
    """A page with what it logged and requested: console errors, page errors, URLs."""

    page: Page
    console_errors: list[str] = field(default_factory=list)
    page_errors: list[str] = field(default_factory=list)
    requests: list[str] = field(default_factory=list)

    def assert_clean(self, expected: str | None = None) -> None:
        """No uncaught exception and no console error (but those starting with ``expected``)."""
        assert not self.page_errors, self.page_errors
        errors = [e for e in self.console_errors if expected is None or not e.startswith(expected)]
        assert not errors, errors


def watch(page: Page) -> Watched:
    """Record ``page``'s console errors, uncaught exceptions, requests and WebSockets."""
    watched = Watched(page)

    def on_console(message: ConsoleMessage) -> None:
        if message.type == "error":
            watched.console_errors.append(f"{message.text} ({message.location})")

    page.on("console", on_console)
    page.on("pageerror", lambda error: watched.page_errors.append(str(error)))
    page.on("request", lambda request: watched.requests.append(request.url))
    page.on("websocket", lambda ws: watched.requests.append(ws.url))
    return watched


def open_page(page: Page, url: str, timeout_ms: float = 30_000) -> None:
    """Load the viewer at ``url`` and wait until every mesh is in and every robot had a frame."""
    page.goto(url, wait_until="load")
    page.wait_for_function(
        "() => window.linkview && window.linkview.meshesLoaded", timeout=timeout_ms
    )
    page.wait_for_function(
        "() => { const n = Object.values(window.linkview.framesApplied);"
        " return n.length > 0 && n.every(c => c > 0); }",
        timeout=timeout_ms,
    )


CAMERA_FOV_DEG = 40.0
"""The page's camera (static/js/scene.js): a perspective camera of this vertical field of
view, Z up, looking from ``linkview.camera.position`` at its ``target``."""


def on_screen(page: Page, points: Sequence[npt.ArrayLike]) -> list[tuple[float, float]]:
    """Where world ``points`` (m) are drawn, in the page's CSS pixels (as a screenshot's),
    worked out from the camera the page reports, not by the page."""
    camera = page.evaluate("window.linkview.camera")
    left, top, width, height = page.evaluate(
        "(() => { const r = document.querySelector('#viewport canvas').getBoundingClientRect();"
        " return [r.left, r.top, r.width, r.height]; })()"
    )
    eye, target = np.array(camera["position"]), np.array(camera["target"])
    back = (eye - target) / np.linalg.norm(eye - target)
    right = np.cross([0.0, 0.0, 1.0], back)
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    focal = 1.0 / math.tan(math.radians(CAMERA_FOV_DEG) / 2)
    out = []
    for point in points:
        seen = np.asarray(point, dtype=np.float64)[:3] - eye
        depth = -float(seen @ back)
        x = focal * height / width * float(seen @ right) / depth
        y = focal * float(seen @ up) / depth
        out.append((left + (x + 1) / 2 * width, top + (1 - y) / 2 * height))
    return out


SCREENSHOTS: Path | None = None
"""Where ``screenshot`` saves (tests/web/conftest.py sets it to a folder of pytest's
temporary ones, kept for the last few runs); None: a new temporary folder."""


def screenshot(page: Page, name: str) -> bytes:
    """A picture of ``page`` (PNG), also saved as ``name`` for people to look at, never in
    the checkout."""
    global SCREENSHOTS
    if SCREENSHOTS is None:
        SCREENSHOTS = Path(tempfile.mkdtemp(prefix="linkview-screenshots-"))
    return page.screenshot(path=str(SCREENSHOTS / name))


# Page-side sampler of the banner: its text every 50 ms, kept only when it changed.
START_BANNER_LOG = """() => {
  const banner = document.getElementById('banner');
  const text = () => banner.hidden ? '' : banner.textContent;
  window.__bannerLog = [text()];
  window.__bannerSample = () => {
    const now = text();
    if (now !== window.__bannerLog[window.__bannerLog.length - 1]) window.__bannerLog.push(now);
  };
  clearInterval(window.__bannerTimer);
  window.__bannerTimer = setInterval(window.__bannerSample, 50);
}"""


OVERLOAD_NOTICE = "The server cannot keep up"


def banner_log(page: Page) -> list[str]:
    """Every banner text the sampler saw, in order (consecutive duplicates removed).

    The banner as it is now is sampled once more first: on a busy page the 50 ms timer
    may not have run since the test saw the banner change. The overload notice is left
    out: it reports this machine's load (CI runs several tests at once), which is honest
    and not the fault a test makes.
    """
    seen: list[str] = page.evaluate("() => { window.__bannerSample(); return window.__bannerLog; }")
    log: list[str] = []
    for text in seen:
        if OVERLOAD_NOTICE not in text and (not log or log[-1] != text):
            log.append(text)
    return log


def _stop(proc: subprocess.Popen[bytes]) -> None:
    proc.terminate()
    try:
        proc.wait(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(timeout=10)


@contextmanager
def mock_process(port: int, log: Path, *args: str) -> Iterator[str]:
    """``python -m server.mock_ctrlx`` on ``port`` (plus ``args``) until the block ends; its URL."""
    url = f"http://127.0.0.1:{port}"
    command = [sys.executable, "-m", "server.mock_ctrlx", "--host", "127.0.0.1"]
    with log.open("ab") as out:
        proc = subprocess.Popen(
            [*command, "--port", str(port), *args],
            cwd=ROOT,
            stdout=out,
            stderr=subprocess.STDOUT,
        )
        try:
            deadline = time.monotonic() + HEALTH_TIMEOUT_S
            while True:
                if proc.poll() is not None:
                    pytest.fail(f"mock exited with {proc.returncode}:\n{log.read_text()}")
                try:
                    with urllib.request.urlopen(f"{url}/mock/faults", timeout=2):
                        break
                except (urllib.error.URLError, ConnectionError, TimeoutError):
                    if time.monotonic() > deadline:
                        pytest.fail(f"the mock did not answer within {HEALTH_TIMEOUT_S} s")
                    time.sleep(0.1)
            yield url
        finally:
            _stop(proc)


def set_faults(mock_url: str, **faults: object) -> None:
    """Switch the mock's faults, e.g. ``outage=True`` (its loopback-only admin endpoint)."""
    request = urllib.request.Request(
        f"{mock_url}/mock/faults",
        data=json.dumps(faults).encode(),
        method="PUT",
        headers={"content-type": "application/json"},
    )
    with urllib.request.urlopen(request, timeout=5) as response:
        assert response.status == 200


def history_json(url: str, t_from: float, t_to: float) -> dict[str, Any]:
    """The demo source's samples between two times (unix s), as ``/api/history`` gives them."""
    query = urlencode({"source": "demo", "from": t_from, "to": t_to, "format": "json"})
    with urllib.request.urlopen(f"{url}/api/history?{query}", timeout=10) as response:
        body: dict[str, Any] = json.loads(response.read())
    return body


def post_json(url: str, body: object) -> tuple[int, Any]:
    """POST ``body`` as JSON; the status and the decoded answer."""
    request = urllib.request.Request(
        url, data=json.dumps(body).encode(), headers={"content-type": "application/json"}
    )
    try:
        with urllib.request.urlopen(request, timeout=10) as response:
            return response.status, json.loads(response.read())
    except urllib.error.HTTPError as error:
        return error.code, json.loads(error.read())
