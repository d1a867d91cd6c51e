"""Phone and tablet sizes: nothing overlaps, every control can be reached, every panel closed."""

from __future__ import annotations

from pathlib import Path

import pytest
from playwright.sync_api import Browser, Page

from tests.conftest import free_port
from tests.web._browser import open_page, server_process, watch

TIMEOUT_MS = 60_000
CLICK_TIMEOUT_MS = 10_000  # a control another element covers never becomes clickable
SIZES = [(390, 844), (768, 1024)]
BLOCKS = ["#hud", "#inspector", "#timeline"]

# Boxes of the page's top-level blocks that are shown, as [left, top, right, bottom].
BOXES = """(selectors) => Object.fromEntries(selectors.flatMap((s) => {
  const e = document.querySelector(s);
  if (!e || e.hidden || getComputedStyle(e).display === 'none') return [];
  const r = e.getBoundingClientRect();
  return [[s, [r.left, r.top, r.right, r.bottom]]];
}))"""

# Every control a person could use, shown and enabled, named for the failure message. The
# timeline's event marks are left out: they sit at their moments, and two events a
# millisecond apart share a spot by design (the mark on top stands for both).
CONTROLS = """(root) => { document.querySelectorAll('[data-phone-test]')
  .forEach((e) => { delete e.dataset.phoneTest; });
  return [...document.querySelectorAll(
    `${root} button, ${root} input, ${root} select, ${root} summary`)]
  .filter((e) => !e.disabled && !e.classList.contains('tl-mark') && e.getClientRects().length > 0
    && getComputedStyle(e).visibility !== 'hidden')
  .map((e, i) => { e.dataset.phoneTest = String(i); return [i, e.id || e.getAttribute('aria-label')
    || e.textContent.trim() || e.tagName]; }); }"""


def _overlaps(boxes: dict[str, list[float]]) -> list[tuple[str, str]]:
    names = sorted(boxes)
    pairs = []
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            al, at, ar, ab = boxes[a]
            bl, bt, br, bb = boxes[b]
            if al < br and bl < ar and at < bb and bt < ab:
                pairs.append((a, b))
    return pairs


def _assert_apart(page: Page, state: str) -> None:
    boxes = page.evaluate(BOXES, BLOCKS)
    width, height = page.viewport_size["width"], page.viewport_size["height"]  # type: ignore[index]
    for name, (left, top, right, bottom) in boxes.items():
        assert left >= 0 and top >= 0 and right <= width and bottom <= height, (state, name, boxes)
    assert not _overlaps(boxes), (state, boxes)


def _reach_every_control(page: Page, root: str, state: str) -> int:
    """Each control is clickable where it is: shown, in the window once scrolled, on top."""
    count = len(page.evaluate(CONTROLS, root))
    for index in range(count):
        # Tagged afresh each time: the timeline redraws its buttons as it goes.
        controls = page.evaluate(CONTROLS, root)
        if index >= len(controls):
            break
        _, name = controls[index]
        assert name, (state, index)
        # trial: every check a click makes (visible, stable, enabled, receives the pointer at
        # its centre, not covered), without the click's effect (a recording saved, a Move).
        try:
            page.locator(f'[data-phone-test="{index}"]').click(trial=True, timeout=CLICK_TIMEOUT_MS)
        except Exception as error:  # noqa: BLE001 - say which control, then fail
            pytest.fail(f"{state}: control {name!r} cannot be clicked: {error}")
    controls = page.evaluate(CONTROLS, root)
    return len(controls)


@pytest.mark.parametrize(("width", "height"), SIZES)
def test_small_screens_nothing_overlaps_and_every_control_is_reachable(
    browser: Browser, tmp_path: Path, width: int, height: int
) -> None:
    page = browser.new_page(viewport={"width": width, "height": height})
    watched = watch(page)
    with server_process(free_port(), tmp_path / "server.log", "--allow-commands") as url:
        open_page(page, f"{url}/", TIMEOUT_MS)
        # The panels start collapsed on a small screen: their headers and the timeline apart.
        _assert_apart(page, "collapsed")
        assert _reach_every_control(page, "body", "collapsed") >= 4
        for panel in ["#hud", "#inspector"]:
            toggle = page.locator(f"{panel} .panel-toggle")
            toggle.click(timeout=CLICK_TIMEOUT_MS)
            assert toggle.get_attribute("aria-expanded") == "true"
            _assert_apart(page, f"{panel} open")
            reached = _reach_every_control(page, "body", f"{panel} open")
            assert reached > 8, (panel, reached)  # the panel's own controls are among them
            # Real clicks on the camera and trail controls: they act and the layout holds.
            shown = page.locator(f"{panel} .toolbar button:not([disabled]):visible")
            for button in shown.all()[:5]:
                if button.get_attribute("id") in ("solve", "move"):
                    continue
                button.click(timeout=CLICK_TIMEOUT_MS)
            _assert_apart(page, f"{panel} open, after clicks")
            # Closed again from its own button, which nothing covers.
            toggle.click(timeout=CLICK_TIMEOUT_MS)
            assert toggle.get_attribute("aria-expanded") == "false"
            _assert_apart(page, f"{panel} closed")
        # One panel open at a time: the other steps aside, and is back once it closes.
        page.click("#hud .panel-toggle")
        assert page.locator("#inspector").is_hidden()
        page.click("#hud .panel-toggle")
        page.locator("#inspector .panel-toggle").click(timeout=CLICK_TIMEOUT_MS)
        assert page.locator("#hud").is_hidden()
        assert page.get_attribute("#inspector .panel-toggle", "aria-expanded") == "true"
    watched.assert_clean(expected="WebSocket connection to")
    page.close()
