"""The page in a real browser against the real server: meshes load, robots move, nothing leaks.

Drives Debian's Chromium (``/usr/bin/chromium``, software WebGL through
SwiftShader) with the playwright package; it never downloads a browser. The
server runs as a subprocess, ``python -m server``, with its embedded mock
controller. A screenshot is saved to ``tests/artifacts/browser.png``.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import pytest
from playwright.sync_api import ConsoleMessage, Error, Request, WebSocket, sync_playwright

from tests.web._browser import CHROMIUM, CHROMIUM_ARGS, ROOT, free_port, server_process

ARTIFACTS = ROOT / "tests" / "artifacts"
LOAD_TIMEOUT_MS = 30_000
NOT_NETWORK = ("data", "blob", "about")
"""URL schemes that never leave the page."""


@pytest.fixture
def server_url(tmp_path: Path) -> Iterator[str]:
    """``python -m server`` on a free loopback port; always terminated afterwards."""
    with server_process(free_port(), tmp_path / "server.log") as url:
        yield url


def _matrices(page: Any, names: list[str]) -> dict[str, list[list[float]]]:
    result: dict[str, list[list[float]]] = page.evaluate(
        "names => Object.fromEntries(names.map(n => [n, window.linkview.linkMatrices(n)]))", names
    )
    return result


def test_page_shows_moving_robots(server_url: str) -> None:
    assert CHROMIUM.exists(), f"{CHROMIUM} is missing: apt-get install chromium"
    console_errors: list[str] = []
    page_errors: list[str] = []
    requests: list[str] = []

    def on_console(message: ConsoleMessage) -> None:
        if message.type == "error":
            console_errors.append(f"{message.text} ({message.location})")

    def on_request(request: Request) -> None:
        requests.append(request.url)

    def on_websocket(ws: WebSocket) -> None:
        requests.append(ws.url)

    def on_page_error(error: Error) -> None:
        page_errors.append(str(error))

    with sync_playwright() as pw:
        browser = pw.chromium.launch(
            executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_ARGS
        )
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 800})
            page.on("console", on_console)
            page.on("pageerror", on_page_error)
            page.on("request", on_request)
            page.on("websocket", on_websocket)

            page.goto(f"{server_url}/", wait_until="load")
            page.wait_for_function(
                "() => window.linkview && window.linkview.meshesLoaded", timeout=LOAD_TIMEOUT_MS
            )
            page.wait_for_function(
                "() => { const n = Object.values(window.linkview.framesApplied);"
                " return n.length > 0 && n.every(c => c > 0); }",
                timeout=LOAD_TIMEOUT_MS,
            )
            assert page.evaluate("window.linkview.connected") is True
            names: list[str] = page.evaluate("Object.keys(window.linkview.framesApplied)")

            first = _matrices(page, names)
            page.wait_for_timeout(500)
            second = _matrices(page, names)

            # Let the camera settle on the robots before the picture is taken.
            page.wait_for_timeout(1000)
            ARTIFACTS.mkdir(exist_ok=True)
            page.screenshot(path=str(ARTIFACTS / "browser.png"))
        finally:
            browser.close()

    for name in names:
        links = first[name]
        assert links and all(len(m) == 16 for m in links), f"{name}: bad link matrices {links}"
    still = [name for name in names if first[name] == second[name]]
    assert not still, f"robots that did not move in 0.5 s: {still}"
    assert not page_errors, page_errors
    assert not console_errors, console_errors

    origin = urlsplit(server_url)
    foreign = [
        url
        for url in requests
        if urlsplit(url).scheme not in NOT_NETWORK
        and (urlsplit(url).hostname, urlsplit(url).port) != (origin.hostname, origin.port)
    ]
    assert not foreign, f"requests outside {server_url}: {foreign}"
    assert any(urlsplit(url).path.endswith(".glb") for url in requests), "no mesh was requested"
