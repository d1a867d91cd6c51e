"""The page in Chromium's default software path: SwiftShader in the GPU process, no --disable-gpu.

The other browser tests pass ``--disable-gpu`` (software compositing, faster to
start); users without a GPU get this path instead, so the page is checked in it
too: it draws the robots, knows it is on a software rasteriser and starts at
the lowest level, and logs no error. Its frame rate is measured by
bench/page_fps.py, not here.
"""

from __future__ import annotations

from pathlib import Path

from playwright.sync_api import sync_playwright

from tests.conftest import free_port
from tests.web._browser import CHROMIUM, CHROMIUM_ARGS, open_page, server_process, watch

TIMEOUT_MS = 60_000
DEFAULT_PATH_ARGS = [arg for arg in CHROMIUM_ARGS if arg != "--disable-gpu"]


def test_page_draws_in_the_default_software_path(tmp_path: Path) -> None:
    assert "--disable-gpu" in CHROMIUM_ARGS and "--disable-gpu" not in DEFAULT_PATH_ARGS
    with (
        server_process(free_port(), tmp_path / "server.log") as url,
        sync_playwright() as pw,
    ):
        browser = pw.chromium.launch(
            executable_path=str(CHROMIUM), headless=True, args=DEFAULT_PATH_ARGS
        )
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 800})
            watched = watch(page)
            open_page(page, f"{url}/", TIMEOUT_MS)
            quality = page.evaluate("window.linkview.quality")
            assert quality["mode"] == "auto" and quality["level"] == 5, quality
            before = page.evaluate("window.linkview.framesApplied")
            page.wait_for_function(
                "(b) => Object.entries(window.linkview.framesApplied)"
                ".every(([name, n]) => n > (b[name] || 0) + 20)",
                arg=before,
                timeout=TIMEOUT_MS,
            )
            info = page.evaluate("window.linkview.renderInfo")
            assert info["calls"] >= 15 and info["triangles"] > 1000, info  # robots drawn
            watched.assert_clean()
        finally:
            browser.close()
