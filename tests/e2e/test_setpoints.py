"""Setpoint nodes over real sockets: an embedded mock serves them, frames carry their pose."""

from __future__ import annotations

import asyncio
import json
import string
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from websockets.asyncio.client import connect

from server.cell import load_cell
from server.config import Settings
from server.mock_ctrlx import DEFAULT_LAG_S
from tests.conftest import running_server

CELL = string.Template("""
[[source]]
name = "line"
$source

[[robot]]
name = "ghosted"
source = "line"
kinematics = { type = "type12", limits = [[-40.0, 40.0], [-40.0, 40.0]] }
joints = [
    { node = "$a0", setpoint = "$s0" },
    { node = "$a1", setpoint = "$s1" },
]
demo_targets = [[0.0, 0.0], [30.0, -25.0]]

[[robot]]
name = "plain"
source = "line"
base = { xyz = [600.0, 0.0, 0.0] }
kinematics = { type = "type12", limits = [[-40.0, 40.0], [-40.0, 40.0]] }
joints = [ { node = "$p0" }, { node = "$p1" } ]
""")
PLC = "plc/app/Application/sym/PLC_PRG"
OPCUA_LINE = "{urn:example:line}Line"
"""Browse paths from the Objects folder, in a namespace of the cell's own (OPC UA's mock serves
them where the cell says)."""
KINDS = {
    "ctrlx": {
        "source": "",
        **{f"a{i}": f"{PLC}/a{i}" for i in range(2)},
        **{f"s{i}": f"{PLC}/s{i}" for i in range(2)},
        **{f"p{i}": f"p/a{i}" for i in range(2)},
    },
    "opcua": {
        "source": 'type = "opcua"',
        **{f"a{i}": f"{OPCUA_LINE}/{{urn:example:line}}Actual{i}" for i in range(2)},
        **{f"s{i}": f"{OPCUA_LINE}/{{urn:example:line}}Commanded{i}" for i in range(2)},
        **{f"p{i}": f"nsu=urn:example:line;s=Plain.A{i}" for i in range(2)},
    },
}


@pytest.mark.parametrize("kind", KINDS)
async def test_an_embedded_mock_serves_setpoints_that_lead_the_actual_joints(
    tmp_path: Path, kind: str, opcua_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """ctrlX by data layer paths; OPC UA by browse paths (the setpoints) and NodeIds."""
    monkeypatch.setenv("LINKVIEW_CACHE_DIR", str(opcua_cache))  # OPC UA's nodesets, built once
    path = tmp_path / "cell.toml"
    path.write_text(CELL.substitute(KINDS[kind]))
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
    # One frame per device time: an OPC UA source delivers its last values again, with their
    # time, while a late publish response keeps it waiting (server/opcua/follow.py).
    ghosted = list({f["t_source"]: f for f in ghosted}.values())
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
