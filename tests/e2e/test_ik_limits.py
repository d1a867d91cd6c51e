"""/ik tells a pose reached only outside the joint limits from one within them, for every family.

Over real sockets, for the IndraMotion MLC kinematic Type 12 (analytic), the
KUKA LBR iiwa (analytic, 8 configurations), a MotionPlus axis group, a DH arm
and a URDF arm (both numerical): a target made by /fk from joints outside the
limits is answered ``ok: false``, "reached only outside the joint limits",
with every solution marked outside (and really reaching it); a target from
joints inside is answered ``ok: true`` with a solution inside.
"""

from __future__ import annotations

import math
import shutil
import textwrap
from pathlib import Path
from typing import Any

import aiohttp
import numpy as np
import pytest

from server.config import Settings
from server.kinematics import matrix_from_pose7, pose7_from_matrix
from tests.conftest import running_server

FIXTURES = Path(__file__).parent / "fixtures"
NUMERIC_CELL = """
[[source]]
name = "demo"

[[robot]]
name = "planar"
source = "demo"
kinematics = { type = "urdf", file = "planar.urdf" }
joints = [ { node = "p1" }, { node = "p2" } ]

[[robot]]
name = "dh3"
source = "demo"
joints = [ { node = "d1", unit = "deg" }, { node = "d2", unit = "deg" },
           { node = "d3", unit = "deg" } ]
[robot.kinematics]
type = "dh"
convention = "standard"
d = [340.0, 0.0, 0.0]
a = [0.0, 400.0, 300.0]
alpha_deg = [90.0, 0.0, 0.0]
limits = [[-30.0, 30.0], [-30.0, 30.0], [-30.0, 30.0]]
"""


async def post(http: aiohttp.ClientSession, url: str, body: dict[str, Any]) -> dict[str, Any]:
    async with http.post(url, json=body) as resp:
        assert resp.status == 200, await resp.text()
        answer: dict[str, Any] = await resp.json()
        return answer


async def tcp_of(
    http: aiohttp.ClientSession, base: str, robot: str, q: list[float]
) -> list[float] | None:
    """The TCP pose at ``q``; None where the family computes none (an axis beyond its limit)."""
    fk = await post(http, f"{base}/api/robots/{robot}/fk", {"joints": [q]})
    tcp: list[float] | None = fk["tcp"][0] if fk["ok"] == [True] else None
    return tcp


async def target(http: aiohttp.ClientSession, base: str, robot: str, q: list[float]) -> list[float]:
    tcp = await tcp_of(http, base, robot, q)
    assert tcp is not None
    return tcp


def tilted(tcp: list[float], degrees: float) -> list[float]:
    """The positioner's table pose turned further about its tilt axis (X, 450 mm up)."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    turn = np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])
    lift = np.eye(4)
    lift[2, 3] = 0.45
    pose = lift @ turn @ np.linalg.inv(lift) @ matrix_from_pose7(np.array(tcp))
    return list(pose7_from_matrix(pose))


async def check(
    http: aiohttp.ClientSession, base: str, robot: str, tcp: list[float], inside: bool
) -> None:
    ik = await post(http, f"{base}/api/robots/{robot}/ik", {"tcp": tcp, "all": True})
    assert ik["solutions"], (robot, ik)
    for q, within in zip(ik["solutions"], ik["within_limits"], strict=True):
        reached = await tcp_of(http, base, robot, q)  # each really reaches the target
        if within or reached is not None:  # (an axis group computes nothing beyond a limit)
            assert reached is not None
            # The largest error seen was 3.4e-11 (m, and quaternion components): 1e-9 leaves
            # room for other platforms' libm and nothing for a wrong solution.
            np.testing.assert_allclose(reached, tcp, atol=1e-9, rtol=0)
    if inside:
        assert ik["ok"] and ik["error"] is None and ik["best"] is not None, (robot, ik)
        assert any(ik["within_limits"]), (robot, ik)
    else:
        assert not ik["ok"] and ik["best"] is None, (robot, ik)
        assert ik["error"] == "reached only outside the joint limits", (robot, ik)
        assert not any(ik["within_limits"]), (robot, ik)


@pytest.mark.parametrize(
    ("robot", "outside", "inside"),
    [
        ("kin12", [1.32, 1.32], [0.3, -0.2]),  # limits +-40 deg
        ("iiwa7", [0.3, 2.5, 0.2, -1.0, 0.4, 0.9, 0.1], [0.3, 0.5, 0.2, -1.0, 0.4, 0.9, 0.1]),
    ],
)
async def test_analytic_families(robot: str, outside: list[float], inside: list[float]) -> None:
    async with running_server(Settings()) as base, aiohttp.ClientSession() as http:
        await check(http, base, robot, await target(http, base, robot, outside), inside=False)
        await check(http, base, robot, await target(http, base, robot, inside), inside=True)


async def test_an_axis_group() -> None:
    async with running_server(Settings()) as base, aiohttp.ClientSession() as http:
        level = await target(http, base, "positioner", [0.0, 0.3])
        await check(http, base, "positioner", tilted(level, 80.0), inside=False)  # +-60 deg
        await check(http, base, "positioner", tilted(level, 40.0), inside=True)


@pytest.mark.parametrize(
    ("robot", "outside", "inside"),
    [("planar", [1.25, 1.25], [0.3, -0.2]), ("dh3", [1.3, 1.3, 1.3], [0.2, 0.3, -0.4])],
)
async def test_numerical_families(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    robot: str,
    outside: list[float],
    inside: list[float],
) -> None:
    monkeypatch.setenv("LINKVIEW_CACHE_DIR", str(tmp_path / "cache"))
    shutil.copy(FIXTURES / "planar.urdf", tmp_path / "planar.urdf")
    cell = tmp_path / "cell.toml"
    cell.write_text(textwrap.dedent(NUMERIC_CELL))
    async with running_server(Settings(cell=cell)) as base, aiohttp.ClientSession() as http:
        await check(http, base, robot, await target(http, base, robot, outside), inside=False)
        await check(http, base, robot, await target(http, base, robot, inside), inside=True)
