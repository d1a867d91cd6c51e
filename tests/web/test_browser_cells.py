"""The page follows the cell file: robots without meshes, a reloaded cell, a broken one.

The server runs ``--cell FILE`` on a cell written here; rewriting the file
makes the server send a new ``hello`` (or a ``cell`` notice when the new
version is unusable), and the page rebuilds its robots.
"""

from __future__ import annotations

import math
from pathlib import Path

from playwright.sync_api import Browser

from tests.conftest import free_port
from tests.web._browser import open_page, post_json, server_process, watch

TIMEOUT_MS = 30_000
SOURCE = '[[source]]\nname = "demo"\n'


def robot(name: str, base_mm: float = 0.0, l4_mm: float = 200.0, extra: str = "") -> str:
    """A Type 12 robot with no meshes, at ``base_mm`` along X."""
    return f"""
[[robot]]
name = "{name}"
source = "demo"
base = {{ xyz = [{base_mm}, 0.0, 0.0] }}
{extra}
joints = [
    {{ node = "motion/axs/{name}_a0/state/values/actual/pos", unit = "deg" }},
    {{ node = "motion/axs/{name}_a1/state/values/actual/pos", unit = "deg" }},
]

[robot.kinematics]
type = "type12"
L1 = 200.0
L2 = 150.0
L3 = 100.0
L4 = {l4_mm}
L5 = 100.0
limits = [[-150.0, 150.0], [-150.0, 150.0]]
"""


def test_robots_without_meshes_and_a_reloaded_cell(browser: Browser, tmp_path: Path) -> None:
    cell = tmp_path / "cell.toml"
    cell.write_text(SOURCE + robot("bare"))
    with server_process(free_port(), tmp_path / "server.log", "--cell", str(cell)) as url:
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        watched = watch(page)
        open_page(page, f"{url}/?quality=5", TIMEOUT_MS)
        # No mesh: a ball per link frame and sticks between them are drawn instead.
        assert page.evaluate("window.linkview.robotState('bare').visible")
        assert page.evaluate("window.linkview.robotState('bare').standIns") == 4
        page.wait_for_timeout(200)
        assert page.evaluate("window.linkview.renderInfo.triangles") > 500
        before = page.evaluate("window.linkview.linkMatrices('bare')[0]")

        # Saved again: the robot moved and a second one joined.
        cell.write_text(SOURCE + robot("bare", base_mm=500.0) + robot("other", base_mm=-500.0))
        page.wait_for_function(
            "() => 'other' in window.linkview.framesApplied"
            " && window.linkview.framesApplied.other > 0",
            timeout=TIMEOUT_MS,
        )
        assert page.locator("article.robot").count() == 2
        after = page.evaluate("window.linkview.linkMatrices('bare')[0]")
        assert abs((after[12] - before[12]) - 0.5) < 1e-6, (before[12], after[12])
        assert page.evaluate(
            "[...document.querySelectorAll('#selected-robot option')].map(o => o.value)"
        ) == ["bare", "other"]

        # A broken version: the running cell stays and the banner says why.
        cell.write_text(SOURCE + robot("bare") + "[[robot]]\nname = 3\n")
        page.wait_for_function(
            "() => document.getElementById('banner').textContent"
            ".startsWith('The cell file was not reloaded')",
            timeout=TIMEOUT_MS,
        )
        assert page.locator("article.robot").count() == 2

        # Fixed, with one robot fewer and one whose mechanism cannot close everywhere
        # (a shorter L4: near a0 = 100 deg, a1 = -120 deg it has no pose).
        free = robot("free", -500.0, 150.0, "demo_targets = [[0.0, 0.0], [20.0, -20.0]]")
        cell.write_text(SOURCE + robot("bare") + free)
        page.wait_for_function(
            "() => !('other' in window.linkview.framesApplied)", timeout=TIMEOUT_MS
        )
        page.wait_for_function("() => document.getElementById('banner').hidden", timeout=TIMEOUT_MS)
        assert page.locator("article.robot").count() == 2

        # Sent where the mechanism cannot close: it keeps its last good pose, greyed,
        # with the error beside it, and comes back when it can be posed again.
        page.wait_for_function(
            "() => window.linkview.framesApplied.free > 0 && "
            "!window.linkview.robotState('free').greyed",
            timeout=TIMEOUT_MS,
        )
        target = [math.radians(100.0), math.radians(-120.0)]
        status, _ = post_json(f"{url}/api/robots/free/move", {"joints": target})
        assert status == 202
        page.wait_for_function(
            "() => (window.linkview.robotState('free').note || '').includes('unreachable')",
            timeout=TIMEOUT_MS,
        )
        state = page.evaluate("window.linkview.robotState('free')")
        assert state["greyed"] and state["visible"], state
        posed = page.evaluate("window.linkview.linkMatrices('free')")
        page.wait_for_timeout(300)
        assert page.evaluate("window.linkview.linkMatrices('free')") == posed  # held
        assert "unreachable" in page.inner_text("article.robot[data-robot='free'] .robot-error")
        tags = {tag["robot"]: tag for tag in page.evaluate("window.linkview.labels")}
        assert "unreachable" in tags["free"]["note"]  # under its name in the view
        # The mock holds a commanded pose (30 s); the next command ends the hold.
        status, _ = post_json(f"{url}/api/robots/free/move", {"joints": [0.0, 0.0]})
        assert status == 202
        page.wait_for_function(
            "() => !window.linkview.robotState('free').greyed", timeout=TIMEOUT_MS
        )
        watched.assert_clean()
        page.close()
