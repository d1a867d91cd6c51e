"""The Clearance toggle in a real browser: two arms whose bases interpenetrate, named and boxed."""

from __future__ import annotations

from pathlib import Path

from playwright.sync_api import Browser

from tests.clearance.cells import two_arms
from tests.conftest import free_port
from tests.web._browser import ROOT, open_page, server_process, watch

TIMEOUT_MS = 60_000


def test_the_clearance_toggle_names_and_boxes_the_touching_links(
    browser: Browser, tmp_path: Path
) -> None:
    cell = two_arms(tmp_path, 0.15)
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    watched = watch(page)
    with server_process(free_port(), tmp_path / "server.log", "--cell", str(cell)) as url:
        open_page(page, f"{url}/?quality=5", 3 * TIMEOUT_MS)
        toggle = page.get_by_role("checkbox", name="warn when links of different robots come close")
        assert not toggle.is_checked()  # off by default: nothing said, nothing boxed
        assert page.evaluate("window.linkview.clearance")["highlighted"] == []
        assert not page.locator("#clearance").is_visible()
        toggle.check()
        page.wait_for_function(
            "() => window.linkview.clearance.highlighted.length === 2", timeout=TIMEOUT_MS
        )
        shown = page.evaluate("window.linkview.clearance")
        assert shown["highlighted"] == [["left", "link0"], ["right", "link0"]]
        line = page.get_by_role("status").filter(has_text="Clearance")
        assert line.inner_text() == "Clearance: left link0 and right link0: touching"
        artifacts = ROOT / "tests" / "artifacts"
        artifacts.mkdir(exist_ok=True)
        page.screenshot(path=str(artifacts / "clearance.png"))
        toggle.uncheck()
        assert page.evaluate("window.linkview.clearance")["highlighted"] == []
        assert not page.locator("#clearance").is_visible()
    watched.assert_clean(expected="WebSocket connection to")
    page.close()
