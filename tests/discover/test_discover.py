"""``discover``: the controller describes itself, and the cell written from that runs.

Against the mock on a free loopback port (in process, or as its own process
for the command line), then the written cell through ``check`` and the server.
"""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import subprocess
import sys
import tomllib
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from websockets.asyncio.client import connect

from server.cell import CellError, load_cell
from server.ctrlx import DataLayerClient
from server.discover import SourceSpec, describe, starter_cell
from server.discover.units import mapping
from server.mock_ctrlx import AxisGroup, Machine, SimAxis, Trafo, build_app, demo_groups
from server.protocol import decode_frames
from tests.conftest import demo_cell, free_port
from tests.ctrlx.helpers import USER, running
from tests.web._browser import ROOT, mock_process, server_process

FIXTURES = ROOT / "tests" / "urdf" / "fixtures"
ENV = {"LINKVIEW_CTRLX_PASSWORD": "boschrexroth"}


def source_for(url: str) -> SourceSpec:
    return SourceSpec("ctrl", url, "boschrexroth", "LINKVIEW_CTRLX_PASSWORD")


async def discovered(machine: Machine | None = None) -> tuple[str, object]:
    """The starter cell text for a mock of ``machine`` (default: the demo machine)."""
    app = build_app(machine) if machine is not None else build_app()
    async with running(app) as mock, DataLayerClient(mock.url, USER) as client:
        controller = await describe(client)
        return starter_cell(controller, source_for(mock.url), "test"), controller


async def test_the_mock_describes_its_axes_and_kinematics() -> None:
    async with running() as mock, DataLayerClient(mock.url, USER) as client:
        controller = await describe(client)
    axes = {a.name: a for a in controller.axes}
    assert len(axes) == 11 and controller.notes == ()
    kin12 = axes["kin12_a0"]
    assert (kin12.unit, kin12.kind, kin12.limits) == ("deg", "ROTATIONAL", (-40.0, 40.0))
    assert kin12.node == "motion/axs/kin12_a0/state/values/actual/pos"
    assert kin12.setpoint == "motion/axs/kin12_a0/state/values/ipo/pos"
    assert kin12.value is not None and -40.0 <= kin12.value <= 40.0
    assert axes["pos_turn"].limits == (None, None)
    kins = {k.name: k for k in controller.kinematics}
    assert kins["kin12"].axes == ("kin12_a0", "kin12_a1")
    assert kins["kin12"].trafo == "IndraMotionType12"
    assert kins["kin12"].params["L2"] == (150.0, "mm")
    assert kins["iiwa"].axes == tuple(f"iiwa_a{i}" for i in range(1, 8))


async def test_the_starter_cell_runs_the_controllers_robots_as_the_demo_cell_does(
    tmp_path: Path,
) -> None:
    text, _ = await discovered()
    path = tmp_path / "cell.toml"
    path.write_text(text)
    cell = load_cell(path, env=ENV, cache_dir=tmp_path)
    robots = {r.name: r for r in cell.robots}
    assert {n: r.family for n, r in robots.items()} == {
        "iiwa": "dh",
        "kin12": "type12",
        "pos": "axis_group",
    }
    (source,) = cell.sources
    assert source.password == "boschrexroth" and source.url.startswith("http://127.0.0.1:")
    for robot in robots.values():
        for joint in robot.joints:
            assert joint.node.endswith("/state/values/actual/pos")
            assert joint.setpoint and joint.setpoint.endswith("/state/values/ipo/pos")
    # The kinematics came from the controller's parameters: the same motion as the demo cell's.
    demo = {r.name: r for r in demo_cell().robots}
    rng = np.random.default_rng(3)
    for mine, theirs, span in (("iiwa", "iiwa7", 1.5), ("kin12", "kin12", 0.6)):
        q = rng.uniform(-span, span, (20, len(robots[mine].joints)))
        q = np.clip(q, robots[mine].limits[:, 0], robots[mine].limits[:, 1])
        got, ok = robots[mine].kinematics.link_poses(q)
        want, ok_want = demo[theirs].kinematics.link_poses(q)
        assert np.array_equal(ok, ok_want) and ok.any()
        np.testing.assert_allclose(got[ok], want[ok], atol=1e-12)
        # The limits are the controller's axis limits (cfg/lim).
        group = next(g for g in demo_groups() if g.name == mine)
        lo_hi = np.radians([[axis.lo, axis.hi] for axis in group.axes])
        np.testing.assert_allclose(robots[mine].limits, lo_hi, atol=1e-12)


async def test_unknown_transformations_odd_units_and_loose_axes(tmp_path: Path) -> None:
    arm = tuple(SimAxis(f"J{i}", "rad", 1.0, 2.0, -3.0, 3.0) for i in range(1, 7))
    trafo = Trafo("SixAxisArticulated", (("a2", 0.4, "m"),), tuple(f"A{i}" for i in range(1, 7)))
    gantry = (SimAxis("gantry_x", "m", 0.5, 1.0, 0.0, 1.2), SimAxis("gantry_z", "mm", 100, 500))
    spindle = (SimAxis("Spindle", "deg", 360.0, 720.0),)
    machine = Machine(
        groups=[
            AxisGroup("Robot 1", arm, ((0.0,) * 6,), kinematics=trafo),
            AxisGroup("g", gantry, ((0.0, 0.0),)),
            AxisGroup("s", spindle, ((0.0,),)),
        ]
    )
    text, _ = await discovered(machine)
    parsed = tomllib.loads(text)
    names = [r["name"] for r in parsed["robot"]]
    assert names == ["Robot_1", "gantry", "axes"]
    arm_robot, gantry_robot, loose = parsed["robot"]
    assert arm_robot["kinematics"] == {"type": "urdf", "file": "Robot_1.urdf"}
    assert [j["unit"] for j in arm_robot["joints"]] == ["rad"] * 6
    assert "TODO: which URDF" in text and "SixAxisArticulated" in text
    axes = gantry_robot["kinematics"]["axes"]
    assert [(a["name"], a["type"], a["parent"]) for a in axes] == [
        ("gantry_x", "linear", ""),
        ("gantry_z", "linear", "gantry_x"),
    ]
    assert axes[0]["limits"] == [0.0, 1200.0]  # m on the controller, mm in the cell
    assert [j["unit"] for j in gantry_robot["joints"]] == ["m", "mm"]
    assert [a["name"] for a in loose["kinematics"]["axes"]] == ["Spindle"]
    path = tmp_path / "cell.toml"
    path.write_text(text)
    # Until the URDF the TODO asks for is there, check names the key and the file.
    with pytest.raises(CellError) as caught:
        load_cell(path, env=ENV, cache_dir=tmp_path / "cache")
    named = f'robot[0] "{arm_robot["name"]}".kinematics.file'
    assert [key for key, _ in caught.value.problems] == [named]
    assert "Robot_1.urdf" in caught.value.problems[0][1]
    shutil.copy(FIXTURES / "serial6.urdf", tmp_path / "Robot_1.urdf")
    cell = load_cell(path, env=ENV, cache_dir=tmp_path / "cache")
    assert [r.family for r in cell.robots] == ["urdf", "axis_group", "axis_group"]


def test_units_the_cell_cannot_take_directly_become_a_scale() -> None:
    assert mapping("µm", "LINEAR") == mapping("um", None)
    assert (mapping("µm", "LINEAR").unit, mapping("µm", "LINEAR").scale) == ("mm", 1e-3)
    assert (mapping("inch", "LINEAR").unit, mapping("inch", "LINEAR").scale) == ("mm", 25.4)
    guessed = mapping("grad", "ROTATIONAL")
    assert (guessed.unit, guessed.guessed) == ("deg", True)
    assert mapping(None, "LINEAR").unit == "mm"


def run(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "server", *args],
        cwd=ROOT,
        env={**os.environ, **(env or {})},
        text=True,
        capture_output=True,
        timeout=60,
    )


def test_discover_then_serve_end_to_end_over_real_sockets(tmp_path: Path) -> None:
    logs = tmp_path / "logs"  # apart from the cell: the server watches the cell's folder
    logs.mkdir()
    cell = tmp_path / "cell" / "cell.toml"
    cell.parent.mkdir()
    with mock_process(free_port(), logs / "mock.log") as mock_url:
        found = run("discover", mock_url, "-o", str(cell), env=ENV)
        assert found.returncode == 0, found.stderr
        assert "11 axes, 2 kinematics" in found.stdout
        assert "kinematics kin12: IndraMotionType12; axes kin12_a0, kin12_a1" in found.stdout
        assert "motion/axs/pos_tilt/state/values/actual/pos" in found.stdout
        again = run("discover", mock_url, "-o", str(cell), env=ENV)
        assert again.returncode == 2 and "exists" in again.stderr
        wrong = run("discover", mock_url, "-o", str(tmp_path / "x.toml"),
                    env={"LINKVIEW_CTRLX_PASSWORD": "nope"})  # fmt: skip
        assert wrong.returncode == 1 and "401" in wrong.stderr and "Traceback" not in wrong.stderr
        checked = run("check", str(cell), env=ENV)
        assert checked.returncode == 0, checked.stderr
        assert len(checked.stdout.splitlines()) == 3
        with server_process(free_port(), logs / "server.log", "--cell", str(cell), env=ENV) as url:
            frames = asyncio.run(frames_of_every_robot(url))
            with urllib.request.urlopen(f"{url}/api/robots", timeout=5) as response:
                listed = json.loads(response.read())
    hello, seen = frames
    assert [r["name"] for r in hello["robots"]] == ["iiwa", "kin12", "pos"]
    assert set(seen) == {0, 1, 2}
    for robot in listed:
        for joint in robot["joints"]:
            assert joint["node"].endswith("actual/pos") and joint["setpoint"].endswith("ipo/pos")
            assert joint["value"] is not None and joint["source_unit"] == "deg"
            assert joint["value_si"] == pytest.approx(np.radians(joint["value"]))


async def frames_of_every_robot(url: str) -> tuple[dict[str, object], dict[int, object]]:
    """``hello``, then a protocol-2 frame with poses and a setpoint for every robot."""
    seen: dict[int, object] = {}
    async with (
        asyncio.timeout(30),
        connect(url.replace("http", "ws") + "/ws", subprotocols=["linkview.2"]) as ws,  # type: ignore[list-item]
    ):
        hello: dict[str, object] = {}
        while len(seen) < 3 or not hello:
            message = await ws.recv()
            if isinstance(message, str):
                parsed = json.loads(message)
                hello = parsed if parsed["type"] == "hello" else hello
                continue
            for robot in decode_frames(message).robots:
                if robot.ok and robot.setpoint is not None:
                    seen[robot.robot_index] = robot
    return hello, seen


def test_setpoints_only_where_every_joint_has_one_and_unknown_units_are_todos(
    tmp_path: Path,
) -> None:
    from server.discover import Axis, Controller

    axes = (
        Axis("arm_a", "motion/axs/arm_a/state/values/actual/pos", "deg", "ROTATIONAL", 1.0,
             "motion/axs/arm_a/state/values/ipo/pos"),
        Axis("arm_b", "motion/axs/arm_b/state/values/actual/pos", "grad", None, None, None),
    )  # fmt: skip
    text = starter_cell(Controller("http://plc", axes, ()), source_for("http://plc"), "test")
    (robot,) = tomllib.loads(text)["robot"]
    assert all("setpoint" not in joint for joint in robot["joints"])
    assert "TODO: the controller gives the unit 'grad'" in text
    path = tmp_path / "cell.toml"
    path.write_text(text)
    (loaded,) = load_cell(path, env=ENV, cache_dir=tmp_path).robots
    assert loaded.setpoint_nodes == ()
