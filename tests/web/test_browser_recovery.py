"""The page in a real browser when things go wrong: a server restart, a controller outage.

The banner is sampled page-side every 50 ms through each outage: it may change
at most twice (on, off), never flip between texts.
"""

from __future__ import annotations

from pathlib import Path

from playwright.sync_api import Browser, Page

from tests.conftest import free_port
from tests.web._browser import (
    START_BANNER_LOG,
    banner_log,
    mock_process,
    open_page,
    server_process,
    set_faults,
    watch,
)

TIMEOUT_MS = 30_000


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


def wait_frames_after(page: Page, before: int) -> None:
    page.wait_for_function(
        f"() => Object.values(window.linkview.framesApplied).reduce((a, b) => a + b, 0)"
        f" > {before + 10}",
        timeout=TIMEOUT_MS,
    )


def test_page_reconnects_by_itself_when_the_server_restarts(
    browser: Browser, tmp_path: Path
) -> None:
    port, log = free_port(), tmp_path / "server.log"
    page = browser.new_page()
    watched = watch(page)
    with server_process(port, log) as url:
        open_page(page, f"{url}/?quality=5", TIMEOUT_MS)
        page.wait_for_function("() => document.getElementById('banner').hidden")
        page.evaluate(START_BANNER_LOG)
    # The server is gone: the page says so and keeps what it drew.
    page.wait_for_function("() => !window.linkview.connected", timeout=TIMEOUT_MS)
    page.wait_for_function("() => !document.getElementById('banner').hidden", timeout=TIMEOUT_MS)
    assert "lost" in banner(page)
    assert page.inner_text("#pill-server") == "server: lost, reconnecting"
    assert page.inner_text("#pill-controllers") == "controller: unknown"
    page.wait_for_function("() => window.linkview.robotState('iiwa7').greyed")
    assert page.evaluate("window.linkview.robotState('iiwa7').visible")  # the last pose stays
    page.wait_for_timeout(1000)  # reconnection attempts fail meanwhile
    before = frames_applied(page)
    with server_process(port, log):
        page.wait_for_function("() => window.linkview.connected", timeout=TIMEOUT_MS)
        wait_frames_after(page, before)
        page.wait_for_function("() => document.getElementById('banner').hidden", timeout=TIMEOUT_MS)
        assert page.inner_text("#pill-server") == "server: connected"
        page.wait_for_function("() => !window.linkview.robotState('iiwa7').greyed")
        log_ = banner_log(page)
    assert log_[0] == "" and log_[-1] == "", log_
    assert len(log_) - 1 <= 2, f"the banner changed {len(log_) - 1} times: {log_}"
    # Chromium itself logs each refused connection attempt; the page logs nothing.
    watched.assert_clean(expected="WebSocket connection to")
    page.close()


def test_a_controller_that_is_away_then_has_an_outage(browser: Browser, tmp_path: Path) -> None:
    page = browser.new_page()
    watched = watch(page)
    mock_port = free_port()
    mock_url = f"http://127.0.0.1:{mock_port}"
    with server_process(free_port(), tmp_path / "server.log", "--ctrlx", mock_url) as url:
        # Nothing listens at the controller's address yet.
        page.goto(f"{url}/?quality=5")
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
        assert page.inner_text("#pill-controllers") == "controller: error"
        assert page.inner_text("#pill-server") == "server: connected"
        # A real controller (not an embedded mock, no --allow-commands): nothing may move it.
        assert page.evaluate("window.linkview.sim.robot") is None
        assert page.is_hidden("#sim")
        off = page.get_by_role("region", name="Simulation (off)")
        assert off.is_visible() and "--allow-commands" in off.inner_text()  # and how to enable it
        # Before any frame the robots are drawn at their zero pose, greyed.
        page.wait_for_function(
            "() => ['kin12', 'iiwa7', 'positioner'].every(n => {"
            " const s = window.linkview.robotState(n); return s.visible && s.greyed; })",
            timeout=TIMEOUT_MS,
        )
        applied = page.evaluate("window.linkview.framesApplied")
        assert applied == {"kin12": 0, "iiwa7": 0, "positioner": 0}
        matrices = page.evaluate("window.linkview.linkMatrices('iiwa7')")
        # At zero the arm stands straight up: its last link is high above its base.
        assert matrices[-1][14] > 1.0, matrices[-1]

        with mock_process(mock_port, tmp_path / "mock.log") as mock:
            # The controller is there now: the same page gets going without a reload.
            page.wait_for_function(
                "() => Object.values(window.linkview.framesApplied).every(c => c > 0)",
                timeout=TIMEOUT_MS,
            )
            page.wait_for_function(
                "() => document.getElementById('banner').hidden", timeout=TIMEOUT_MS
            )
            page.wait_for_function("() => !window.linkview.robotState('iiwa7').greyed")
            page.evaluate(START_BANNER_LOG)
            set_faults(mock, outage=True)
            page.wait_for_function(
                "() => /controller: (stale|error)/"
                ".test(document.getElementById('pill-controllers').textContent)",
                timeout=TIMEOUT_MS,
            )
            page.wait_for_function(
                "() => !document.getElementById('banner').hidden", timeout=TIMEOUT_MS
            )
            assert "Controller demo" in banner(page)
            # The socket is fine: only the controller is down.
            assert page.inner_text("#pill-server") == "server: connected"
            page.wait_for_function("() => window.linkview.robotState('iiwa7').greyed")
            assert "no live data" in page.evaluate("window.linkview.robotState('iiwa7').note")
            page.wait_for_timeout(1500)  # the outage lasts; status messages keep coming
            # Each card says how long it has had no data, not its rate from before.
            card = page.locator(".robot-state").nth(1)
            page.wait_for_function(
                "() => /^no data for [1-9][0-9]* s · last good at \\d\\d:\\d\\d:\\d\\d$/"
                ".test(document.querySelectorAll('.robot-state')[1].textContent)",
                timeout=TIMEOUT_MS,
            )
            assert "frames/s" not in card.inner_text() and "latency" not in card.inner_text()
            before = frames_applied(page)
            set_faults(mock, outage=False)
            wait_frames_after(page, before)
            page.wait_for_function(
                "() => document.getElementById('banner').hidden", timeout=TIMEOUT_MS
            )
            assert page.inner_text("#pill-controllers") == "controller: connected"
            page.wait_for_function("() => !window.linkview.robotState('iiwa7').greyed")
            page.wait_for_function(
                "() => document.querySelectorAll('.robot-state')[1].textContent"
                ".includes('frames/s · latency')",
                timeout=TIMEOUT_MS,
            )
            log_ = banner_log(page)
    assert log_[0] == "" and log_[-1] == "", log_
    assert len(log_) - 1 <= 2, f"the banner changed {len(log_) - 1} times: {log_}"
    watched.assert_clean()
    page.close()
