"""Changing the cell from the page: a joint's sign, a description for a TODO robot, the diff,
the save that keeps the file's comments and key order; and nothing without --allow-edits.

The cells run on embedded mocks holding each robot still (one demo target), so
what the page draws can be compared with ``/fk`` exactly.
"""

from __future__ import annotations

import json
import shutil
import urllib.request
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from playwright.sync_api import Browser, Page

from tests.commissioning.cells import SOURCE, STILL, TODO_ARM, TODO_URDF_ARM, cell_file
from tests.conftest import free_port
from tests.web._browser import (
    ROOT,
    Watched,
    on_screen,
    open_page,
    post_json,
    server_process,
    watch,
)

TIMEOUT_MS = 120_000  # the page renders in software on a shared machine
FIXTURES = ROOT / "tests" / "urdf" / "fixtures"

COMMENT = "# Commissioning test cell. This comment, and the order of the keys, must survive.\n"
CELL = COMMENT + SOURCE + STILL + TODO_ARM
DISCOVERED = COMMENT + SOURCE + STILL + TODO_URDF_ARM
"""The arm as ``discover`` leaves it when it cannot compute its transformation: a URDF
file that is not there (run as a placeholder chain, with --allow-edits)."""


def cell_in(tmp_path: Path, text: str = CELL) -> Path:
    folder = tmp_path / "cell"
    (folder / "arm_description" / "urdf").mkdir(parents=True)
    shutil.copy(FIXTURES / "serial6.urdf", folder / "arm_description" / "urdf" / "serial6.urdf")
    return cell_file(folder, text)


def robots(url: str) -> dict[str, Any]:
    with urllib.request.urlopen(f"{url}/api/robots", timeout=10) as response:
        return {r["name"]: r for r in json.loads(response.read())}


def open_for(browser: Browser, url: str, robot: str) -> Watched:
    """A page of the server at ``url``, commissioning ``robot``; what it logs is watched."""
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    watched = watch(page)
    page.set_default_timeout(TIMEOUT_MS)
    open_page(page, f"{url}/?quality=5", TIMEOUT_MS)
    page.select_option("#selected-robot", robot)
    page.wait_for_function(f"() => window.linkview.commission.robot === '{robot}'")
    return watched


def drawn_links(page: Page, robot: str) -> np.ndarray:
    """Link origins as the page draws them (world frame)."""
    matrices = page.evaluate(f"window.linkview.linkMatrices('{robot}')")
    return np.array([m[12:15] for m in matrices])


def test_flipping_a_joints_sign_moves_the_model_at_once(browser: Browser, tmp_path: Path) -> None:
    cell = cell_in(tmp_path)
    log = tmp_path / "server.log"
    with server_process(free_port(), log, "--cell", str(cell), "--allow-edits") as url:
        watched = open_for(browser, url, "still")
        page = watched.page
        page.locator('article.robot[data-robot="still"] details.mapping summary').click()
        page.get_by_label("flip the sign of a0 of still").click()
        # The server runs the change at once: the still robot's a0 reads -10 degrees now.
        page.wait_for_function(
            "() => { const r = window.linkview.readout('still');"
            " return r && Math.abs(r.joints[0] * 180 / Math.PI + 10) < 1e-4; }"
        )
        joints = page.evaluate("window.linkview.readout('still').joints")
        status, fk = post_json(f"{url}/api/robots/still/fk", {"joints": [joints], "links": True})
        assert status == 200
        base = np.array(robots(url)["still"]["base"][:3])
        np.testing.assert_allclose(
            drawn_links(page, "still"), np.array(fk["links"][0])[:, :3] + base, atol=1e-5
        )
        assert page.evaluate("window.linkview.mapping('still')[0].scale") == -0.001
        shown = page.evaluate("window.linkview.commission.edits")
        assert shown["unsaved"] == 1 and shown["diff"] is None
        assert cell.read_text() == CELL  # nothing written yet
        watched.assert_clean()


def test_a_description_for_a_todo_robot_is_chosen_shown_as_a_diff_and_saved(
    browser: Browser, tmp_path: Path
) -> None:
    cell = cell_in(tmp_path, DISCOVERED)
    log = tmp_path / "server.log"
    env = {"LINKVIEW_CACHE_DIR": str(tmp_path / "cache")}
    with server_process(free_port(), log, "--cell", str(cell), "--allow-edits", env=env) as url:
        watched = open_for(browser, url, "arm")
        page = watched.page
        (warning,) = robots(url)["arm"]["warnings"]
        assert "arm.urdf is not there: drawn as a placeholder chain" in warning
        # The base gizmo goes on the robot chosen (and off again).
        page.get_by_label("move the robot's base with a gizmo in the view").check()
        assert page.evaluate("window.linkview.commission.gizmo") == "arm"
        page.get_by_label("move the robot's base with a gizmo in the view").uncheck()
        assert page.evaluate("window.linkview.commission.gizmo") is None
        page.get_by_label("list the robot descriptions on the server's machine").click()
        page.wait_for_function("() => window.linkview.commission.describe.found.length > 0")
        found = page.evaluate("window.linkview.commission.describe.found")
        assert all(len(entry["joints"]) == 6 for entry in found)
        assert found[0]["origin"] == "cell folder"
        page.get_by_label("preview arm_description/urdf/serial6.urdf").click()
        page.wait_for_function("() => window.linkview.commission.describe.ghostParts > 0")
        # A ball per link and the sticks: the description's nine links.
        assert page.evaluate("window.linkview.commission.describe.preview.links") == 9
        page.screenshot(path=str(tmp_path / "preview.png"))
        page.get_by_label("describe arm by arm_description/urdf/serial6.urdf").click()
        # The placeholder chain (7 links) gives way to the description's 9.
        page.wait_for_function(
            "() => window.linkview.readout('arm')"
            " && window.linkview.linkMatrices('arm').length === 9"
        )
        assert robots(url)["arm"]["warnings"] == []
        # Review: the diff is shown; only then can it be written.
        page.get_by_label("show the diff of the unsaved changes to the cell file").click()
        page.wait_for_function("() => window.linkview.commission.edits.diff !== null")
        diff = page.evaluate("window.linkview.commission.edits.diff")
        assert page.get_by_label("diff of the unsaved changes", exact=True).is_visible()
        assert '-kinematics = { type = "urdf", file = "arm.urdf" }' in diff
        assert '+kinematics = { type = "urdf", file = "arm_description/urdf/serial6.urdf" }' in diff
        page.get_by_label("write the changes shown to the cell file").click()
        page.wait_for_function("() => window.linkview.commission.edits.backup === 'cell.toml.bak'")
        watched.assert_clean()
    saved = cell.read_text()
    assert (cell.parent / "cell.toml.bak").read_text() == DISCOVERED
    # The comments stay, and so does the order of every key that was there.
    assert [ln for ln in saved.splitlines() if ln.startswith("#")] == [
        ln for ln in DISCOVERED.splitlines() if ln.startswith("#")
    ]
    keys = [ln.split(" =")[0] for ln in DISCOVERED.splitlines() if " = " in ln and ln[0].isalpha()]
    kept = [ln.split(" =")[0] for ln in saved.splitlines() if " = " in ln and ln[0].isalpha()]
    assert kept == keys
    assert saved.index('name = "arm"') < saved.index("# TODO: which URDF (or xacro) describes arm?")
    assert '    { node = "motion/axs/A1/state/values/actual/pos", joint = "j1" },' in saved


def test_without_allow_edits_every_control_says_how_and_the_server_refuses(
    browser: Browser, tmp_path: Path
) -> None:
    cell = cell_in(tmp_path)
    with server_process(free_port(), tmp_path / "server.log", "--cell", str(cell)) as url:
        watched = open_for(browser, url, "arm")
        page = watched.page
        page.locator('article.robot[data-robot="still"] details.mapping summary').click()
        page.wait_for_function("() => window.linkview.commission.edits.whyNot !== null")
        shown = page.evaluate("window.linkview.commission")
        controls = shown["controls"]
        # The mapping tables (2 + 6 joints, 6 controls each), placing, calibrating, describing.
        assert len(controls) > 8 * 6 + 8
        for control in controls:
            assert control["disabled"], control
            assert "--allow-edits" in control["title"], control
        assert "--allow-edits" in page.locator(".edit-state").text_content()
        status = page.evaluate(
            """async () => {
                const answer = await fetch('/api/cell/changes', {method: 'POST',
                    headers: {'content-type': 'application/json'},
                    body: JSON.stringify({changes: [{op: 'joint', robot: 'still', joint: 'a0',
                                                     scale: -0.001}]})});
                return [answer.status, (await answer.json()).detail];
            }"""
        )
        assert status[0] == 403 and "--allow-edits" in status[1]
        watched.assert_clean(expected="Failed to load resource")
    assert cell.read_text() == CELL


def drag_gizmo_along_x(page: Page, base: list[float], pixels: float) -> None:
    """Find the base gizmo's X arrow on screen (the handle the pointer is over) from the base
    at ``base`` (m), and drag it ``pixels`` along world +X on screen, as a user does."""
    base_at = np.array(base[:3])
    (origin, ahead) = on_screen(page, [base_at, base_at + [0.05, 0.0, 0.0]])
    direction = np.subtract(ahead, origin) / np.linalg.norm(np.subtract(ahead, origin))
    for step in range(8, 200, 4):  # out along the arrow until the pointer is over it
        at = np.add(origin, direction * step)
        page.mouse.move(*at)
        if page.evaluate("window.linkview.commission.gizmoAxis") == "X":
            break
    else:
        raise AssertionError("the pointer never came over the gizmo's X arrow")
    page.mouse.down()
    for share in (0.25, 0.5, 0.75, 1.0):
        page.mouse.move(*np.add(at, direction * pixels * share))
    page.mouse.up()


@pytest.mark.parametrize("view", ["3d", "2d"])
def test_dragging_the_base_gizmo_places_the_robot(
    view: str, browser: Browser, tmp_path: Path
) -> None:
    cell = cell_in(tmp_path)
    log = tmp_path / "server.log"
    with server_process(free_port(), log, "--cell", str(cell), "--allow-edits") as url:
        watched = open_for(browser, url, "still")
        page = watched.page
        if view == "2d":
            page.select_option("#view-kind", "2d")
            page.wait_for_function("() => window.linkview.view.view === '2d'")
        page.get_by_label("move the robot's base with a gizmo in the view").check()
        before = robots(url)["still"]["base"]
        drag_gizmo_along_x(page, before, 80)
        # Let go: the server places the robot (a change, not yet saved) and says where.
        page.wait_for_function(
            "() => window.linkview.commission.edits.unsaved === 1", timeout=TIMEOUT_MS
        )
        after = robots(url)["still"]["base"]
        assert after[0] > before[0] + 0.01, (before, after)  # along +X ...
        np.testing.assert_allclose(after[1:], before[1:], atol=1e-9)  # ... and only along it
        place = page.evaluate("window.linkview.commission.place")
        assert float(place["x"]) == pytest.approx(after[0] * 1000, abs=1e-3)
        assert cell.read_text() == CELL  # nothing written yet
        watched.assert_clean()
