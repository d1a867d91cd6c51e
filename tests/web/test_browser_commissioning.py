"""Commissioning on the page: the setpoint ghost and the node mapping of every joint.

The ghost test runs the mock as its own process with a long lag, writes the
cell with ``discover`` and serves it; the page's setpoint ghost must lead the
actual pose by exactly that lag. The mapping test holds a robot still on an
embedded mock, so the raw values the page shows can be compared with
``/api/robots`` digit for digit.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import urllib.request
from pathlib import Path
from typing import Any

import numpy as np
from playwright.sync_api import Browser

from tests.conftest import free_port
from tests.web._browser import ROOT, mock_process, open_page, post_json, server_process

TIMEOUT_MS = 180_000  # generous: the page renders in software, on a shared machine
LAG_S = 0.15
ENV = {"LINKVIEW_CTRLX_PASSWORD": "boschrexroth"}


def residual(recent: list[dict[str, Any]], lag: float) -> float:
    """Mean |setpoint(t) - actual(t + lag)| (rad) over the samples where both are known."""
    t = np.array([r["t_source"] for r in recent])
    actual = np.array([r["actual"] for r in recent])
    setpoint = np.array([r["setpoint"] for r in recent])
    inside = t + lag <= t[-1]
    ahead = np.column_stack(
        [np.interp(t[inside] + lag, t, actual[:, j]) for j in range(actual.shape[1])]
    )
    return float(np.abs(setpoint[inside] - ahead).mean())


def test_the_setpoint_ghost_leads_the_actual_pose_by_the_mocks_lag(
    browser: Browser, tmp_path: Path
) -> None:
    logs, cell = tmp_path / "logs", tmp_path / "cell" / "cell.toml"
    logs.mkdir()
    cell.parent.mkdir()
    lag_ms = str(LAG_S * 1000)
    with mock_process(free_port(), logs / "mock.log", "--lag-ms", lag_ms) as mock_url:
        found = subprocess.run(
            [sys.executable, "-m", "server", "discover", mock_url, "-o", str(cell)],
            cwd=ROOT, env={**os.environ, **ENV},
            text=True, capture_output=True, timeout=60,
        )  # fmt: skip
        assert found.returncode == 0, found.stderr
        with server_process(free_port(), logs / "server.log", "--cell", str(cell), env=ENV) as url:
            page = browser.new_page(viewport={"width": 1280, "height": 800})
            page.set_default_timeout(TIMEOUT_MS)
            open_page(page, f"{url}/?quality=5", TIMEOUT_MS)
            state = "window.linkview.following('iiwa')"
            assert page.evaluate(f"{state}.on") is False  # off by default
            assert page.evaluate(f"{state}.ghostMatrices") is None
            page.get_by_label("draw the setpoint of iiwa as a ghost").check()
            page.wait_for_function(f"() => {state}.recent.length >= 200", timeout=TIMEOUT_MS)
            shown = page.evaluate(state)
            robots = json.loads(urllib.request.urlopen(f"{url}/api/robots", timeout=5).read())
            drawn_joints = shown["ghostJoints"]
            status, fk = post_json(
                f"{url}/api/robots/iiwa/fk", {"joints": [drawn_joints], "links": True}
            )
            assert status == 200 and fk["ok"] == [True]
            page.get_by_label("draw the setpoint of iiwa as a ghost").uncheck()
            assert page.evaluate(f"{state}.on") is False
    assert shown["on"] and shown["ghostVisible"]
    assert "TCP" in shown["readout"] and "mm" in shown["readout"]
    # The ghost shows a setpoint the server sent, drawn where /fk puts that pose (the
    # robot stands at the origin).
    assert drawn_joints in [r["setpoint"] for r in shown["recent"]]
    (iiwa,) = [r for r in robots if r["name"] == "iiwa"]
    assert iiwa["base"][:3] == [0.0, 0.0, 0.0]
    drawn = np.array([m[12:15] for m in shown["ghostMatrices"]])
    np.testing.assert_allclose(drawn, np.array(fk["links"][0])[:, :3], atol=1e-5)
    # The setpoint now is where the actual pose will be one lag later.
    recent = shown["recent"]
    lags = np.arange(0.0, 0.4, 0.005)
    errors = [residual(recent, lag) for lag in lags]
    best = lags[int(np.argmin(errors))]
    assert abs(best - LAG_S) <= 0.015, (best, errors)
    assert min(errors) < 0.1 * errors[0], "the ghost is really ahead, not on top of the robot"
    largest = shown["largest"]
    assert largest["tcp"] > 0.0 and max(largest["joints"]) > 0.0


def test_the_mapping_table_shows_what_api_robots_says(browser: Browser, tmp_path: Path) -> None:
    cell = tmp_path / "cell" / "cell.toml"
    cell.parent.mkdir()
    cell.write_text(
        """
[[source]]
name = "line"

[[robot]]
name = "still"
source = "line"
kinematics = { type = "type12", limits = [[-40.0, 40.0], [-40.0, 40.0]] }
joints = [
    { node = "plc/app/Application/sym/PLC_PRG/a0", unit = "deg", scale = 0.001, offset = 2.0 },
    { node = "plc/app/Application/sym/PLC_PRG/a1", unit = "rad", scale = 0.5, offset = -0.1 },
]
demo_targets = [[10000.0, 0.2]]
"""
    )
    with server_process(free_port(), tmp_path / "server.log", "--cell", str(cell)) as url:
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        page.set_default_timeout(TIMEOUT_MS)
        open_page(page, f"{url}/?quality=5", TIMEOUT_MS)
        page.locator('article.robot[data-robot="still"] details.mapping summary').click()
        table = page.get_by_label("node mapping of still")
        assert table.is_visible()
        page.wait_for_function(
            "() => window.linkview.mapping('still').every(row => row.raw !== '—')",
            timeout=TIMEOUT_MS,
        )
        rows = page.evaluate("window.linkview.mapping('still')")
        cells = table.locator("tr[data-joint] td.raw").all_text_contents()
        (api,) = json.loads(urllib.request.urlopen(f"{url}/api/robots", timeout=5).read())
    assert cells == [row["raw"] for row in rows]
    for row, joint in zip(rows, api["joints"], strict=True):
        assert row["joint"] == joint["name"] and row["node"] == joint["node"]
        assert (row["unit"], row["scale"], row["offset"]) == (
            joint["source_unit"],
            joint["scale"],
            joint["offset"],
        )
        assert float(row["raw"]) == round(joint["value"], 3)
    assert [float(row["raw"]) for row in rows] == [10000.0, 0.2]
    assert [row["value"] for row in rows] == ["12.000 deg", "0.000 rad"]
