"""The 2D view in Chromium without WebGL: the cell drawn, moving, orbited, fitted, boxed, ghosted.

Chromium runs with ``--disable-webgl --disable-3d-apis``, so the page draws with
Canvas 2D (static/js/view2d). What is drawn is read from screenshots: a robot's
colour inside the box it covers on screen (its bounding box projected by the
page's camera), and what changes between two pictures.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from playwright.sync_api import Browser, Page

from tests.clearance.cells import two_arms
from tests.conftest import free_port
from tests.web._browser import Watched, open_page, server_process, watch
from tests.web._pixels import changed, crop, of_colour, shot

TIMEOUT_MS = 60_000
ROBOTS = ("kin12", "iiwa7", "positioner")


@pytest.fixture(scope="module")
def server_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    with server_process(free_port(), tmp_path_factory.mktemp("server") / "server.log") as url:
        yield url


def open_2d(browser: Browser, url: str) -> Watched:
    """The page at 1280x800, once the 2D view has drawn every coarse mesh, labels hidden."""
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    watched = watch(page)
    open_page(page, url, TIMEOUT_MS)
    page.wait_for_function(
        "() => { const v = window.linkview.view; return v.view === '2d' && v.pending === 0"
        " && window.linkview.renderInfo.triangles > 500; }",
        timeout=TIMEOUT_MS,
    )
    # The robots' name tags: out of the pictures compared here.
    page.get_by_role("checkbox", name="robot names in the view").uncheck()
    # A scene at rest is drawn once more only where something changed (frame_gate.js): the
    # last coarse mesh and the tags' going, in the next animation frames.
    settle(page)
    return watched


def settle(page: Page, frames: int = 3) -> None:
    """Let the page run ``frames`` animation frames: what was asked for is on screen.

    Not frames drawn: a frame with nothing new to show is not drawn (frame_gate.js).
    """
    page.evaluate(
        "(n) => new Promise((done) => { const next = () => --n ? requestAnimationFrame(next)"
        " : done(); requestAnimationFrame(next); })",
        frames,
    )


def in_view(page: Page, box: dict[str, float]) -> dict[str, float]:
    """The part of ``box`` (px) on the view's canvas, between the panels."""
    view = page.locator("#viewport canvas").bounding_box()
    assert view is not None
    return {
        "left": max(box["left"], view["x"]),
        "top": max(box["top"], view["y"]),
        "right": min(box["right"], view["x"] + view["width"]),
        "bottom": min(box["bottom"], view["y"] + view["height"]),
    }


def camera_at_rest(page: Page, timeout_s: float = 60.0) -> None:
    """Wait until the camera holds still from one animation frame to the next.

    The orbit's damping decays per frame, not per second: on a loaded machine, with
    fewer frames, it runs for longer than any fixed wait.
    """
    deadline = time.monotonic() + timeout_s
    before = page.evaluate("window.linkview.camera")
    while True:
        settle(page, 2)
        now = page.evaluate("window.linkview.camera")
        if all(np.allclose(now[key], before[key], atol=1e-6) for key in now):  # a µm: at rest
            return
        assert time.monotonic() < deadline, f"the camera still moves: {before} -> {now}"
        before = now


def still(page: Page) -> None:
    """Pause the timeline: the robots hold their pose; wait for the camera to come to rest."""
    page.get_by_role("button", name="pause on this moment (space)").click()
    page.wait_for_function("() => window.linkview.timeline.mode === 'paused'")
    camera_at_rest(page)
    settle(page)


def union(a: dict[str, float], b: dict[str, float]) -> dict[str, float]:
    """The smallest box (px) holding both."""
    return {
        "left": min(a["left"], b["left"]),
        "top": min(a["top"], b["top"]),
        "right": max(a["right"], b["right"]),
        "bottom": max(a["bottom"], b["bottom"]),
    }


def test_without_webgl_every_robot_is_drawn_in_its_colour_and_moves(
    no_webgl_browser: Browser, server_url: str
) -> None:
    watched = open_2d(no_webgl_browser, f"{server_url}/")
    page = watched.page
    shown = page.evaluate("window.linkview.view")
    assert shown["view"] == "2d" and shown["shown"]
    badge = page.get_by_role("status").filter(has_text="2D view")
    assert badge.inner_text().startswith("2D view: this browser has no WebGL.")
    assert "graphics acceleration" in badge.inner_text()  # and how to turn WebGL on
    assert page.locator("#view-kind option[value='3d']").is_disabled()
    # Opaque panels over the 2D view: no blending of them anew each frame (static/css).
    panel = "getComputedStyle(document.getElementById('hud')).backgroundColor"
    assert page.evaluate(panel) == "rgb(253, 253, 253)"
    page.get_by_role("checkbox", name="TCP trail", exact=True).uncheck()  # the robots alone move
    settle(page)

    def box_now(name: str) -> dict[str, float]:
        return dict(page.evaluate("(n) => window.linkview.screenBox(n)", name))

    # The robots move while the picture is taken: each one's box covers where it was
    # just before the picture and just after.
    before = {name: box_now(name) for name in ROBOTS}
    first = shot(page)
    boxes = {name: in_view(page, union(before[name], box_now(name))) for name in ROBOTS}
    joints = {
        name: page.evaluate("(n) => window.linkview.readout(n).joints", name) for name in ROBOTS
    }
    for name in ROBOTS:
        colour = page.evaluate("(n) => window.linkview.robotState(n).color", name)
        inside = of_colour(crop(first, boxes[name]), colour)
        # The robot's own colour, lit and shaded: none where it is not drawn; kin12, small in
        # this view, showed 199 px at its smallest once.
        assert inside >= 100, (name, colour, inside)
    # Every robot moves on (its joints change), and so does its picture.
    page.wait_for_function(
        "(q) => Object.entries(q).every(([n, j]) => window.linkview.readout(n).joints"
        ".some((v, i) => Math.abs(v - j[i]) > 0.15))",
        arg=joints,
        timeout=TIMEOUT_MS,
    )
    settle(page)
    second = shot(page)
    for name in ROBOTS:
        moved = int(changed(crop(first, boxes[name]), crop(second, boxes[name])).sum())
        # Its TCP marker alone: under 100; kin12, small in this view, changed 286 px once.
        assert moved >= 150, (name, moved)
    watched.assert_clean(expected="WebSocket connection to")
    page.close()


def test_orbit_zoom_fit_all_and_the_view_buttons_change_the_picture(
    no_webgl_browser: Browser, server_url: str
) -> None:
    watched = open_2d(no_webgl_browser, f"{server_url}/")
    page = watched.page
    still(page)
    before = shot(page)
    camera = page.evaluate("window.linkview.camera")
    view = page.locator("#viewport canvas").bounding_box()
    assert view is not None
    x, y = view["x"] + view["width"] / 2, view["y"] + view["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    page.mouse.move(x + 160, y + 30, steps=12)
    page.mouse.up()
    page.wait_for_timeout(1500)
    settle(page)
    orbited = shot(page)
    assert page.evaluate("window.linkview.camera")["position"] != camera["position"]
    assert changed(before, orbited).sum() > 5000
    page.mouse.move(x, y)
    page.mouse.wheel(0, 800)  # zoom out
    page.wait_for_timeout(1500)
    settle(page)
    zoomed = shot(page)
    assert changed(orbited, zoomed).sum() > 5000
    page.get_by_role("button", name="fit all robots in the view (Home)").click()
    settle(page)
    fitted = shot(page)
    assert changed(zoomed, fitted).sum() > 5000
    # Fitted: every robot is inside the view again.
    for name in ROBOTS:
        box = page.evaluate("(n) => window.linkview.screenBox(n)", name)
        assert view["x"] - 2 <= box["left"] and box["right"] <= view["x"] + view["width"] + 2
    page.get_by_role("button", name="view from the top").click()
    settle(page)
    assert changed(fitted, shot(page)).sum() > 5000
    watched.assert_clean(expected="WebSocket connection to")
    page.close()


def test_a_simulation_ghost_is_drawn(no_webgl_browser: Browser, server_url: str) -> None:
    watched = open_2d(no_webgl_browser, f"{server_url}/")
    page = watched.page
    page.select_option("#selected-robot", "kin12")
    page.get_by_role("button", name="focus the camera on kin12").click()
    still(page)
    page.click("#target-from-tcp")
    settle(page)
    box = page.evaluate("window.linkview.screenBox('kin12')")
    before = shot(page)
    page.click("#solve")
    page.wait_for_function("() => window.linkview.sim.ghosts > 0", timeout=TIMEOUT_MS)
    settle(page)
    after = shot(page)
    # The ghosts (each configuration reaching the target) over the robot, translucent.
    area = {"left": box["left"] - 60, "top": box["top"] - 60, "right": box["right"] + 60}
    area["bottom"] = box["bottom"] + 60
    area = in_view(page, area)
    drawn = int(changed(crop(before, area), crop(after, area)).sum())
    assert drawn >= 1000, drawn
    watched.assert_clean(expected="WebSocket connection to")
    page.close()


def test_the_clearance_highlight_is_drawn(no_webgl_browser: Browser, tmp_path: Path) -> None:
    cell = two_arms(tmp_path, 0.15)  # their bases interpenetrate
    with server_process(free_port(), tmp_path / "server.log", "--cell", str(cell)) as url:
        watched = open_2d(no_webgl_browser, f"{url}/")
        page = watched.page
        before = shot(page)
        page.get_by_role("checkbox", name="warn when links of different robots come close").check()
        page.wait_for_function(
            "() => window.linkview.clearance.highlighted.length === 2", timeout=TIMEOUT_MS
        )
        settle(page)
        around = [
            page.evaluate("(n) => window.linkview.screenBox(n)", n) for n in ("left", "right")
        ]
        area = in_view(
            page,
            {
                "left": min(b["left"] for b in around) - 20,
                "top": min(b["top"] for b in around) - 20,
                "right": max(b["right"] for b in around) + 20,
                "bottom": max(b["bottom"] for b in around) + 20,
            },
        )
        before, after = crop(before, area), crop(shot(page), area)
        r, g, b = after[..., 0], after[..., 1], after[..., 2]
        # The boxes' red (0xe02020: green and blue alike), not the arms' orange (no blue).
        red = (r - g > 0.3) & (np.abs(g - b) < 0.1) & (b > 0.06)
        boxed = int((changed(before, after) & red).sum())
        assert boxed >= 100, boxed
        watched.assert_clean(expected="WebSocket connection to")
        page.close()
