"""Bringing up a cell that ``discover`` wrote, on the page: the steps, and the machine it is for.

Shared by ``test_browser_bring_up.py`` (which checks the saved cell) and
``docs/commissioning_screenshots.py`` (which photographs each step for
docs/commissioning.md). The machine the standalone mock stands for is written
out here: the LBR iiwa at the origin, the Type 12 at (-750, 350) mm, and the
demo cell's tilting positioner (``cells/demo.toml``) standing at x = 650 mm:
its tilt axis along +X, 450 mm up, the turntable 100 mm above that.

Moving the robots (to touch a mark) is the one thing not done on the page: an
operator jogs them with the pendant; here ``/ik`` and ``/move`` stand in.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from playwright.sync_api import Page
from scipy.spatial.transform import Rotation

from tests.web._browser import ROOT, post_json

ENV = {"LINKVIEW_CTRLX_PASSWORD": "boschrexroth"}
FIXTURE = ROOT / "tests" / "web" / "fixtures" / "lbr_iiwa7_description"
URDF = "lbr_iiwa7_description/urdf/lbr_iiwa7_r800.urdf"
MARK = np.array([0.1, 0.0, 0.0, 1.0])  # on the turntable, in its frame (m)
REACHING = np.radians([0.0, 30.0, 0.0, -80.0, 0.0, 60.0, 0.0]).tolist()
"""An iiwa posture reaching out over the positioner, within the mock's joint limits."""

Shoot = Callable[[str], None]
"""Called with a step's name where the page shows it (a screenshot, or nothing)."""


def pose(xyz_m: tuple[float, ...], rpy_deg: tuple[float, ...]) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_euler("xyz", rpy_deg, degrees=True).as_matrix()
    matrix[:3, 3] = xyz_m
    return matrix


def rz(angle: float) -> np.ndarray:
    return pose((0, 0, 0), (0, 0, math.degrees(angle)))


POSITIONER = pose((0.65, 0.0, 0.0), (0, 0, 0))
TILT = pose((0.0, 0.0, 0.45), (0, 90, 0))  # the demo cell's axes
TURN = pose((-0.1, 0.0, 0.0), (0, -90, 0))


def true_table(tilt: float, turn: float) -> np.ndarray:
    """The turntable's frame in the cell at these axis positions (rad), as the machine is."""
    return POSITIONER @ TILT @ rz(tilt) @ TURN @ rz(turn)


def discover(mock_url: str, cell: Path) -> str:
    """``python -m server discover`` writes the starter cell; its text."""
    found = subprocess.run(
        [sys.executable, "-m", "server", "discover", mock_url, "-o", str(cell)],
        cwd=ROOT, env={**os.environ, **ENV}, text=True, capture_output=True, timeout=60,
    )  # fmt: skip
    assert found.returncode == 0, found.stderr
    shutil.copytree(FIXTURE, cell.parent / FIXTURE.name)  # a description beside it
    return cell.read_text()


def get(url: str) -> Any:
    with urllib.request.urlopen(url, timeout=10) as response:
        return json.loads(response.read())


def sample(url: str, robot: str) -> Any:
    deadline = time.monotonic() + 30
    while True:
        try:
            return get(f"{url}/api/robots/{robot}/tcp")
        except urllib.error.HTTPError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.1)


def move_to(url: str, robot: str, q: list[float]) -> None:
    status, answer = post_json(f"{url}/api/robots/{robot}/move", {"joints": q})
    assert status == 202, answer
    deadline = time.monotonic() + 60
    while not np.allclose(sample(url, robot)["joints"], q, rtol=0, atol=1e-9):
        assert time.monotonic() < deadline, f"{robot} did not reach {q}"
        time.sleep(0.1)


def touch(url: str, point: np.ndarray) -> None:
    """The iiwa's TCP (as in ``REACHING``, nearly down) onto a point of the cell."""
    status, fk = post_json(f"{url}/api/robots/iiwa/fk", {"joints": [REACHING]})
    assert status == 200
    tcp = [*point[:3].tolist(), *fk["tcp"][0][3:]]
    status, ik = post_json(f"{url}/api/robots/iiwa/ik", {"tcp": tcp, "joints_ref": REACHING})
    assert status == 200 and ik["ok"], ik
    move_to(url, "iiwa", ik["best"])
    np.testing.assert_allclose(sample(url, "iiwa")["world"][:3], point[:3], atol=1e-7)


def changes(page: Page) -> int:
    count: int = page.evaluate("window.linkview.commission.edits.unsaved")
    return count


def choose(page: Page, robot: str) -> None:
    page.select_option("#selected-robot", robot)
    page.wait_for_function(f"() => window.linkview.commission.robot === '{robot}'")


def calibrate(
    page: Page, url: str, axis: str, positions: list[list[float]], set_to: str, shoot: Shoot
) -> str:
    """Samples of the mark at the positioner's ``positions``, fitted and applied; the fit."""
    page.get_by_label("frame calibrated").select_option(axis)
    page.get_by_label("robot whose TCP takes the samples").select_option("iiwa")
    for k, q in enumerate(positions):
        move_to(url, "pos", q)
        touch(url, true_table(*q) @ MARK)
        page.get_by_label("take a sample: the measuring robot's TCP now").click()
        page.wait_for_function(
            f"() => window.linkview.commission.calibration.samples.length === {k + 1}"
        )
    page.get_by_label("fit the axis frame to the samples").click()
    page.wait_for_function("() => window.linkview.commission.calibration.result !== null")
    text: str = page.evaluate("window.linkview.commission.calibration.text")
    shoot(f"calibrate-{axis}")
    page.get_by_label("what applying the fit changes").select_option(set_to)
    before = changes(page)
    page.get_by_label("make the fitted frame the robot's, in the cell").click()
    page.wait_for_function(f"() => window.linkview.commission.edits.unsaved === {before + 1}")
    return text


def bring_up(page: Page, url: str, shoot: Shoot) -> dict[str, str]:
    """Every step on the page, from the discovered cell to the saved one; the fits' texts."""
    shoot("discovered")
    # The iiwa's description, from the cell's folder.
    choose(page, "iiwa")
    page.get_by_label("list the robot descriptions on the server's machine").click()
    page.get_by_label(f"preview {URDF}").click()
    page.wait_for_function("() => window.linkview.commission.describe.ghostParts > 0")
    shoot("describe")
    page.get_by_label(f"describe iiwa by {URDF}").click()
    page.wait_for_function("() => window.linkview.commission.edits.unsaved === 1")
    # The Type 12 placed by numbers.
    choose(page, "kin12")
    for key, value in (("x", "-750"), ("y", "350"), ("z", "0"), ("yaw", "0")):
        page.get_by_label(f"base {key} in").fill(value)
    page.get_by_label("place the robot's base at these numbers").click()
    page.wait_for_function("() => window.linkview.commission.edits.unsaved === 2")
    shoot("place")
    # The tilt axis: the mark (the table turned half round) at three tilts; then the
    # turntable: the mark at three turns, the table level.
    choose(page, "pos")
    tilt_positions = [[math.radians(a), math.pi] for a in (0, 30, 60)]
    fits = {"tilt": calibrate(page, url, "pos_tilt", tilt_positions, "base", shoot)}
    turn_positions = [[0.0, math.radians(a)] for a in (150, 200, 250)]
    fits["turn"] = calibrate(page, url, "pos_turn", turn_positions, "axis", shoot)
    # Check: the Mapping table, each joint's node and value, editable.
    page.locator('article.robot[data-robot="pos"] details.mapping summary').click()
    shoot("check")
    # Reviewed and saved.
    page.get_by_label("show the diff of the unsaved changes to the cell file").click()
    page.wait_for_function("() => window.linkview.commission.edits.diff !== null")
    shoot("review")
    page.get_by_label("write the changes shown to the cell file").click()
    page.wait_for_function("() => window.linkview.commission.edits.unsaved === 0")
    page.wait_for_function("() => window.linkview.commission.edits.backup !== null")
    shoot("saved")
    return fits
