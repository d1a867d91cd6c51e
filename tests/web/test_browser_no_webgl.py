"""A browser without WebGL: the page says so, draws the 2D view, and everything else stays live."""

from __future__ import annotations

from pathlib import Path

from playwright.sync_api import Browser

from tests.conftest import free_port
from tests.web._browser import open_page, server_process, watch

TIMEOUT_MS = 60_000


def test_without_webgl_the_page_says_so_and_stays_live(
    no_webgl_browser: Browser, tmp_path: Path
) -> None:
    page = no_webgl_browser.new_page(viewport={"width": 1280, "height": 800})
    watched = watch(page)
    with server_process(free_port(), tmp_path / "server.log") as url:
        open_page(page, f"{url}/", TIMEOUT_MS)
        notice = page.get_by_role("status").filter(has_text="2D view")
        assert notice.is_visible()
        assert notice.inner_text().startswith("2D view: this browser has no WebGL.")
        assert "graphics acceleration" in notice.inner_text()  # and how to turn it on
        assert page.inner_text("#pill-server") == "server: connected"
        assert page.inner_text("#pill-controllers") == "controller: connected"
        # The readouts follow the robots: the arm's joints change from one moment to the next.
        first = page.evaluate("window.linkview.readout('iiwa7').joints")
        page.wait_for_function(
            "(q) => window.linkview.readout('iiwa7').joints"
            ".some((v, i) => Math.abs(v - q[i]) > 1e-4)",
            arg=first,
            timeout=TIMEOUT_MS,
        )
        page.wait_for_function("() => window.linkview.plots.samples > 10", timeout=TIMEOUT_MS)
        assert "frames/s" in page.locator(".robot-state").first.inner_text()
        # Each source says which controller and where: its name and address in plain sight.
        source = page.locator("#sources li").first
        assert source.locator(".name").inner_text().startswith("demo")
        assert source.locator(".address").inner_text().startswith("http://127.0.0.1:")
        assert source.locator(".address").is_visible()
        # The simulation panel works too: it solves and previews without drawing.
        page.select_option("#selected-robot", "kin12")
        page.click("#target-from-tcp")
        page.click("#solve")
        page.wait_for_function(
            "() => document.getElementById('sim-status').textContent.includes('reach')",
            timeout=TIMEOUT_MS,
        )
    watched.assert_clean(expected="WebSocket connection to")
    page.close()
