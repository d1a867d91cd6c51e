"""The Clearance toggle in a real browser: two arms whose bases interpenetrate, named and boxed.

The boxes are looked for on the picture: the outline of each base link's box,
worked out from its mesh (trimesh) and the page's camera, must be drawn in red.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import numpy.typing as npt
import trimesh
from PIL import Image
from playwright.sync_api import Browser, Page

from tests.clearance.cells import two_arms
from tests.conftest import free_port
from tests.web._browser import ROOT, on_screen, open_page, screenshot, server_process, watch

TIMEOUT_MS = 60_000
LINK0 = ROOT / "assets" / "iiwa7" / "link0.glb"
OUTLINE_SHARE = 0.7
"""Of the points along a box's 12 projected edges, the share with a box pixel within 3 px
(a few fall outside the picture or under the panels)."""
EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]
"""A box's 12 edges: corners (indexed by their x, y, z bits) that differ in one coordinate."""


def picture(png: bytes) -> npt.NDArray[np.int16]:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def box_pixels(boxed: npt.NDArray[np.int16], plain: npt.NDArray[np.int16]) -> npt.NDArray[np.bool_]:
    """Pixels that turned the boxes' red (0xe02020, shaded) when the toggle was on."""
    r, g, b = boxed[..., 0], boxed[..., 1], boxed[..., 2]
    reddish = (r > 120) & (r > 2 * g) & (r > 2 * b)
    return reddish & (np.abs(boxed - plain).sum(axis=2) > 60)


def world_box(page: Page, robot: str) -> list[npt.NDArray[np.float64]]:
    """The 8 corners of link0's axis-aligned world box, as three.js's BoxHelper makes it."""
    lo, hi = trimesh.load(LINK0, force="scene").bounds
    local = [np.array([(hi if k >> i & 1 else lo)[i] for i in range(3)] + [1.0]) for k in range(8)]
    matrix = np.array(page.evaluate(f"window.linkview.linkMatrices('{robot}')[0]")).reshape(4, 4).T
    world = np.array([matrix @ c for c in local])[:, :3]
    low, high = world.min(axis=0), world.max(axis=0)
    return [np.array([(high if k >> i & 1 else low)[i] for i in range(3)]) for k in range(8)]


def outline_drawn(red: npt.NDArray[np.bool_], corners: list[tuple[float, float]]) -> float:
    """The share of points along the 12 projected edges with a box pixel within 3 px."""
    hits = total = 0
    for a, b in EDGES:
        for t in np.linspace(0.05, 0.95, 19):
            x = corners[a][0] + t * (corners[b][0] - corners[a][0])
            y = corners[a][1] + t * (corners[b][1] - corners[a][1])
            i, j = int(round(y)), int(round(x))
            total += 1
            hits += bool(red[max(i - 3, 0) : i + 4, max(j - 3, 0) : j + 4].any())
    return hits / total


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
        boxed = picture(screenshot(page, "clearance.png"))
        toggle.uncheck()
        assert page.evaluate("window.linkview.clearance")["highlighted"] == []
        assert not page.locator("#clearance").is_visible()
        page.evaluate("new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
        plain = picture(screenshot(page, "clearance-off.png"))
        # The boxes on the picture: the outline of each link0's world box (its mesh's bounds,
        # read with trimesh, where the page puts the link), projected with the page's camera.
        red = box_pixels(boxed, plain)
        for robot in ("left", "right"):
            corners = world_box(page, robot)
            hit = outline_drawn(red, on_screen(page, corners))
            assert hit >= OUTLINE_SHARE, f"{robot}'s box: {hit:.0%} of its outline drawn"
    watched.assert_clean(expected="WebSocket connection to")
    page.close()
