"""The page in a real browser when things go wrong: a server restart, a controller that is down."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Browser, Page, sync_playwright

from tests.web._browser import CHROMIUM, CHROMIUM_ARGS, free_port, server_process

TIMEOUT_MS = 30_000


@pytest.fixture
def browser() -> Iterator[Browser]:
    assert CHROMIUM.exists(), f"{CHROMIUM} is missing: apt-get install chromium"
    with sync_playwright() as pw:
        chromium = pw.chromium.launch(
            executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_ARGS
        )
        try:
            yield chromium
        finally:
            chromium.close()


def frames_applied(page: Page) -> int:
    total: int = page.evaluate(
        "Object.values(window.linkview.framesApplied).reduce((a, b) => a + b, 0)"
    )
    return total


def banner(page: Page) -> str:
    text: str = page.evaluate(
        "(() => { const b = document.getElementById('banner');"
        " return b.hidden ? '' : b.textContent; })()"
    )
    return text


def test_page_reconnects_by_itself_when_the_server_restarts(
    browser: Browser, tmp_path: Path
) -> None:
    port, log = free_port(), tmp_path / "server.log"
    page = browser.new_page()
    with server_process(port, log) as url:
        page.goto(f"{url}/")
        page.wait_for_function(
            "() => window.linkview && window.linkview.meshesLoaded", timeout=TIMEOUT_MS
        )
        page.wait_for_function("() => window.linkview.connected", timeout=TIMEOUT_MS)
    # The server is gone: the page says so and keeps what it drew.
    page.wait_for_function("() => !window.linkview.connected", timeout=TIMEOUT_MS)
    page.wait_for_function("() => !document.getElementById('banner').hidden", timeout=TIMEOUT_MS)
    assert "lost" in banner(page)
    before = frames_applied(page)
    with server_process(port, log):
        page.wait_for_function("() => window.linkview.connected", timeout=TIMEOUT_MS)
        page.wait_for_function(
            f"() => Object.values(window.linkview.framesApplied).reduce((a, b) => a + b, 0)"
            f" > {before + 10}",
            timeout=TIMEOUT_MS,
        )
        page.wait_for_function("() => document.getElementById('banner').hidden", timeout=TIMEOUT_MS)


def test_page_shows_a_controller_that_cannot_be_reached(browser: Browser, tmp_path: Path) -> None:
    dead = f"http://127.0.0.1:{free_port()}"  # nothing listens there
    with server_process(free_port(), tmp_path / "server.log", "--ctrlx", dead) as url:
        page = browser.new_page()
        page.goto(f"{url}/")
        page.wait_for_function(
            "() => window.linkview && window.linkview.connected", timeout=TIMEOUT_MS
        )
        page.wait_for_function(
            "() => document.getElementById('banner').textContent.includes('cannot reach')",
            timeout=TIMEOUT_MS,
        )
        sources = page.locator("#sources").inner_text()
        assert "error" in sources and "cannot reach" in sources
        assert "cannot reach" in banner(page)
