"""``discover rtde://...`` on the mock UR controller writes a cell that checks and streams."""

from __future__ import annotations

import asyncio
import sys
import tomllib
from pathlib import Path

import numpy as np

from server.cell import load_cell
from server.config import Settings
from server.discover.rtde import starter_cell
from server.discover.ur_models import MODELS
from server.mock_ctrlx import Machine
from server.mock_rtde import RtdeMock, demo_groups
from tests.conftest import running_server
from tests.e2e.test_faults import wait_for_health

ROOT = Path(__file__).resolve().parents[2]


async def discover(*args: str, cwd: Path) -> tuple[int, str, str]:
    process = await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        "server",
        "discover",
        *args,
        cwd=str(cwd),
        env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"},
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    out, err = await asyncio.wait_for(process.communicate(), 60.0)
    assert process.returncode is not None
    return process.returncode, out.decode(), err.decode()


async def test_discover_writes_a_cell_that_check_accepts_and_that_streams(tmp_path: Path) -> None:
    mock = RtdeMock(Machine(demo_groups()))
    await mock.start("127.0.0.1", 0)
    try:
        output = tmp_path / "ur.toml"
        args = (mock.url, "--model", "ur5e", "-o", str(output))
        code, out, err = await discover(*args, cwd=tmp_path)
        assert code == 0, err
        assert "URControl 5.15.0.0: robot mode RUNNING, safety mode NORMAL" in out
        cell = load_cell(output, cache_dir=tmp_path / "cache")
        (robot,) = cell.robots
        assert [j.node for j in robot.joints] == [f"actual_q[{i}]" for i in range(6)]
        assert cell.sources[0].type == "rtde" and cell.sources[0].url == mock.url
        # UR's UR5e at zero, as its published geometry puts the flange: straight out along
        # -X (a2 + a3), offset along -Y (d4 + d6), at d1 - d5 above the base.
        _, tcp, ok = robot.poses(np.zeros(6))
        assert bool(ok)
        np.testing.assert_allclose(tcp[:3, 3], [-0.8172, -0.2329, 0.0628], atol=1e-9)
        async with running_server(Settings(cell=output)) as base:
            health = await wait_for_health(
                base, lambda h: h["sources"][0]["robots"].get("ur5e", {}).get("frames", 0) > 5
            )
            assert health["sources"][0]["robots"]["ur5e"]["ok"]
    finally:
        await mock.close()


async def test_discover_names_a_controller_that_is_not_there(tmp_path: Path) -> None:
    from tests.conftest import free_port

    port = free_port()
    code, _, err = await discover(
        f"rtde://127.0.0.1:{port}", "--model", "ur5e", "-o", str(tmp_path / "c.toml"), cwd=tmp_path
    )
    assert code == 1
    assert f"rtde://127.0.0.1:{port}" in err
    assert not (tmp_path / "c.toml").exists()


async def test_a_model_is_required_since_rtde_does_not_say(tmp_path: Path) -> None:
    code, _, err = await discover("rtde://127.0.0.1", cwd=tmp_path)
    assert code == 2
    assert "--model" in err


def test_device_text_cannot_add_keys_to_the_cell(tmp_path: Path) -> None:
    hostile = 'x"\n[[source]]\nname = "evil"\n# '
    text = starter_cell(
        'rtde://h"\n[x]', 'a"b', MODELS["ur10e"], hostile, tmp_path / "c.toml", hostile
    )
    parsed = tomllib.loads(text)
    assert [s["name"] for s in parsed["source"]] == ['a"b']
    assert parsed["source"][0]["url"] == 'rtde://h"\n[x]'
    assert set(parsed) == {"source", "robot"}


def test_a_ur_description_package_found_above_the_cell_is_used(tmp_path: Path) -> None:
    package = tmp_path / "ws" / "ur_description"  # beside the cell's folder
    (package / "urdf").mkdir(parents=True)
    (package / "package.xml").write_text("<package><name>ur_description</name></package>")
    (package / "urdf" / "ur.urdf.xacro").write_text("<robot/>")
    cells = tmp_path / "ws" / "cells"
    cells.mkdir()
    text = starter_cell("rtde://10.0.0.2", "ur", MODELS["ur5e"], "", cells / "c.toml", "-")
    kinematics = tomllib.loads(text)["robot"][0]["kinematics"]
    assert kinematics["type"] == "urdf"
    assert (cells / kinematics["file"]).resolve() == (package / "urdf" / "ur.urdf.xacro")
    assert kinematics["args"] == {"ur_type": "ur5e", "name": "ur5e"}
