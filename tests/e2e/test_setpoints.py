"""Setpoint nodes over real sockets: an embedded mock serves them, frames carry their pose."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import numpy as np
from websockets.asyncio.client import connect

from server.cell import load_cell
from server.config import Settings
from server.mock_ctrlx import DEFAULT_LAG_S
from tests.conftest import running_server

CELL = """
[[source]]
name = "line"

[[robot]]
name = "ghosted"
source = "line"
kinematics = { type = "type12", limits = [[-40.0, 40.0], [-40.0, 40.0]] }
joints = [
    { node = "plc/app/Application/sym/PLC_PRG/a0", setpoint = "plc/app/Application/sym/PLC_PRG/s0"},
    { node = "plc/app/Application/sym/PLC_PRG/a1", setpoint = "plc/app/Application/sym/PLC_PRG/s1"},
]
demo_targets = [[0.0, 0.0], [30.0, -25.0]]

[[robot]]
name = "plain"
source = "line"
base = { xyz = [600.0, 0.0, 0.0] }
kinematics = { type = "type12", limits = [[-40.0, 40.0], [-40.0, 40.0]] }
joints = [ { node = "p/a0" }, { node = "p/a1" } ]
"""


async def test_an_embedded_mock_serves_setpoints_that_lead_the_actual_joints(
    tmp_path: Path,
) -> None:
    path = tmp_path / "cell.toml"
    path.write_text(CELL)
    cell = load_cell(path, env={}, cache_dir=tmp_path)
    frames: dict[str, list[dict[str, Any]]] = {"ghosted": [], "plain": []}
    async with running_server(Settings(), cell) as base:
        async with asyncio.timeout(30), connect(base.replace("http", "ws") + "/ws") as ws:
            while len(frames["ghosted"]) < 100 or len(frames["plain"]) < 5:
                message = json.loads(await ws.recv())
                if message["type"] == "frame" and message["ok"]:
                    frames[message["robot"]].append(message)
    assert all("setpoint" not in f for f in frames["plain"])
    ghosted = frames["ghosted"]
    assert all(len(f["setpoint"]["links"]) == len(f["links"]) for f in ghosted)
    t = np.array([f["t_source"] for f in ghosted])
    actual = np.array([f["joints"] for f in ghosted])
    setpoint = np.array([f["setpoint"]["joints"] for f in ghosted])
    moving = np.abs(np.diff(actual[:, 0])) > 1e-6
    assert moving.sum() > 20, "the robot moves between its demo targets"
    # The actual joints trail the setpoints: the setpoint is where the robot is next.
    velocity = np.gradient(actual[:, 0], t)
    lead = (setpoint[:, 0] - actual[:, 0])[1:-1][moving[1:]]
    expected = (velocity * DEFAULT_LAG_S)[1:-1][moving[1:]]
    assert np.median(np.abs(lead - expected)) < 0.2 * np.median(np.abs(expected))
