"""The same pose of the demo cell in the 3D view (WebGL) and the 2D view: the robots in one place.

One page, its timeline paused (the robots hold one pose), the camera at rest.
Each robot's silhouette is where the picture changes when that robot alone is
hidden; its bounding box in the 3D view (software WebGL, full meshes) and in the
2D view (Canvas 2D, the coarse meshes) must agree within a few pixels.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
from playwright.sync_api import Browser, Page

from tests.conftest import free_port
from tests.web._browser import open_page, server_process, watch
from tests.web._pixels import bounding_box, changed, crop, shot
from tests.web.test_browser_view2d import TIMEOUT_MS, camera_at_rest, in_view, settle

ROBOTS = ("kin12", "iiwa7", "positioner")
AGREE_PX = 3
"""The coarse meshes stay within 1 % of a link's size; the edges' antialiasing differs."""


def silhouettes(page: Page) -> dict[str, dict[str, Any] | None]:
    """Each robot's silhouette's bounding box (px of the view): what changes when it is hidden."""
    view = in_view(page, {"left": 0, "top": 0, "right": 1280, "bottom": 800})
    everything = steady(page, view)
    boxes = {}
    for name in ROBOTS:
        show = page.get_by_role("checkbox", name=f"show {name}", exact=True)
        show.uncheck()
        hidden = steady(page, view)
        boxes[name] = bounding_box(changed(hidden, everything))
        show.check()
        # Shown again: the picture must be the whole one before the next robot is hidden (on
        # a loaded machine the last one's redraw was once still missing: its place counted
        # as the next robot's).
        deadline = time.monotonic() + 30
        while changed(steady(page, view), everything).sum():
            assert time.monotonic() < deadline, f"{name} was not drawn again"
    return boxes


def steady(page: Page, view: dict[str, float]) -> Any:
    """The view once two screenshots a few frames apart agree (what was asked for is drawn)."""
    settle(page)
    last = crop(shot(page), view)
    deadline = time.monotonic() + 30
    while True:
        settle(page)
        now = crop(shot(page), view)
        if not changed(now, last).sum():
            return now
        assert time.monotonic() < deadline, "the picture never came to rest"
        last = now


def test_both_views_draw_each_robot_in_the_same_place(browser: Browser, tmp_path: Path) -> None:
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    watched = watch(page)
    with server_process(free_port(), tmp_path / "server.log") as url:
        # Level 4: the full meshes, no shadows (a shadow is no part of a silhouette).
        open_page(page, f"{url}/?quality=4", 3 * TIMEOUT_MS)
        assert page.evaluate("window.linkview.view")["view"] == "3d"
        # Labels, and the banner (a loaded machine's overload notice comes and goes), are
        # no part of a silhouette.
        page.evaluate("document.getElementById('banner').style.visibility = 'hidden'")
        page.get_by_role("checkbox", name="robot names in the view").uncheck()
        page.get_by_role("checkbox", name="TCP trail", exact=True).uncheck()
        page.get_by_role("button", name="pause on this moment (space)").click()
        # Paused, the robots are posed from the history window of that moment once it has
        # come (before, the last live frame shows: 65 px apart once on a loaded machine).
        page.wait_for_function(
            "() => { const t = window.linkview.timeline;"
            " return t.mode === 'paused' && t.fetches > 0 && t.loading === 0; }",
            timeout=TIMEOUT_MS,
        )
        camera_at_rest(page)
        settle(page)
        camera = page.evaluate("window.linkview.camera")
        in_3d = silhouettes(page)
        page.select_option("#view-kind", "2d")
        page.wait_for_function(
            "() => { const v = window.linkview.view; return v.view === '2d' && v.pending === 0"
            " && window.linkview.renderInfo.triangles > 500; }",
            timeout=TIMEOUT_MS,
        )
        settle(page)
        now = page.evaluate("window.linkview.camera")
        for key in ("position", "target"):  # where it was: rounding errors apart
            assert np.allclose(now[key], camera[key], atol=1e-6), (key, now, camera)
        badge = page.get_by_role("status").filter(has_text="2D view")
        assert badge.inner_text() == "2D view: chosen under View."
        in_2d = silhouettes(page)
    for name in ROBOTS:
        three, two = in_3d[name], in_2d[name]
        assert three is not None and two is not None, (name, three, two)
        assert three["right"] - three["left"] > 20, (name, three)  # a robot, not a speck
        off = {side: abs(three[side] - two[side]) for side in three}
        assert max(off.values()) <= AGREE_PX, (name, three, two)
    watched.assert_clean(expected="WebSocket connection to")
    page.close()
