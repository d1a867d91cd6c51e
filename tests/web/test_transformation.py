"""Seed 004's Transformation service over REST: round trips for every robot, and bad input."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import aiohttp
import numpy as np

from server.config import Settings
from server.kinematics import matrix_from_pose7, matrix_from_rpy
from server.kinematics.configurations import NUMERICAL, TYPE12_BRANCHES
from tests.conftest import demo_cell, running_mock, running_server


def sample_joints(name: str, rng: np.random.Generator, count: int) -> np.ndarray:
    """Random postures each robot of the default cell can take."""
    if name == "kin12":
        return rng.uniform(-0.7, 0.7, (count, 2))
    if name == "iiwa7":
        limits = np.radians([170, 120, 170, 120, 170, 120, 175])
        return rng.uniform(-0.8 * limits, 0.8 * limits, (count, 7))
    return rng.uniform([-1.0, -3.0], [1.0, 3.0], (count, 2))


async def post(http: aiohttp.ClientSession, url: str, body: Any) -> tuple[int, Any]:
    async with http.post(url, json=body) as resp:
        return resp.status, await resp.json()


async def test_ik_of_fk_returns_to_the_same_tcp_for_every_robot() -> None:
    rng = np.random.default_rng(7)
    async with (
        running_mock() as (_, url),
        running_server(Settings(ctrlx_url=url)) as base,
        aiohttp.ClientSession() as http,
    ):
        for robot in demo_cell().robots:
            api = f"{base}/api/robots/{robot.name}"
            q = sample_joints(robot.name, rng, 5)
            status, fk = await post(http, api + "/fk", {"joints": q.tolist()})
            assert status == 200 and all(fk["ok"]), (robot.name, fk)
            _, expected, _ = robot.poses(q)
            tcp = matrix_from_pose7(np.array(fk["tcp"]))
            np.testing.assert_allclose(tcp, expected, atol=1e-12)
            np.testing.assert_allclose(
                matrix_from_rpy(np.array(fk["rpy"])), expected[:, :3, :3], atol=1e-12
            )
            for q_i, tcp_i in zip(q, fk["tcp"], strict=True):
                body = {"tcp": tcp_i, "joints_ref": q_i.tolist(), "all": True}
                status, ik = await post(http, api + "/ik", body)
                assert status == 200 and ik["ok"] and ik["error"] is None, (robot.name, ik)
                _, again, _ = robot.poses(np.array(ik["best"]))
                # Every family solves exactly here: the errors are some 1e-16 m.
                np.testing.assert_allclose(again[:3, 3], expected_pose(tcp_i)[:3, 3], atol=1e-12)
                if robot.family != "type12":  # Type 12 keeps a fixed TCP orientation
                    np.testing.assert_allclose(again, expected_pose(tcp_i), atol=1e-12)
                assert len(ik["solutions"]) == len(ik["within_limits"]) >= 1
                assert len(ik["configurations"]) == len(ik["solutions"])
                if robot.family != "dh":  # the iiwa's are named by flags (test below)
                    assert set(ik["configurations"]) <= {NUMERICAL, TYPE12_BRANCHES}


def expected_pose(tcp7: list[float]) -> np.ndarray:
    return matrix_from_pose7(np.array(tcp7))


async def test_iiwa_ik_lists_the_starting_configuration_among_all_eight() -> None:
    rng = np.random.default_rng(3)
    robot = next(r for r in demo_cell().robots if r.name == "iiwa7")
    q = sample_joints("iiwa7", rng, 1)[0]
    _, tcp, _ = robot.poses(q)
    async with (
        running_mock() as (_, url),
        running_server(Settings(ctrlx_url=url)) as base,
        aiohttp.ClientSession() as http,
    ):
        _, fk = await post(http, f"{base}/api/robots/iiwa7/fk", {"joints": [q.tolist()]})
        body = {"tcp": fk["tcp"][0], "joints_ref": q.tolist(), "all": True}
        status, ik = await post(http, f"{base}/api/robots/iiwa7/ik", body)
    assert status == 200 and ik["ok"]
    solutions = np.array(ik["solutions"])
    assert solutions.shape[1] == 7 and 1 <= len(solutions) <= 8
    # Each configuration by name (shoulder, elbow and wrist flags), one per solution, distinct.
    names = ik["configurations"]
    assert len(names) == len(solutions) == len(set(names))
    for row, name in zip(solutions, names, strict=True):
        assert name.split(" · ")[1:] == [
            "elbow −" if row[3] < 0 else "elbow +",
            "wrist flip" if row[5] < 0 else "wrist no-flip",
        ]
    assert np.min(np.abs(solutions - q).max(axis=1)) < 1e-8
    np.testing.assert_allclose(ik["best"], q, atol=1e-8)
    assert np.allclose(tcp, robot.poses(np.array(ik["best"]))[1], atol=1e-9)


async def test_bad_requests_get_422_and_unknown_robot_404() -> None:
    bad_fk = [
        {"joints": [[0.1]]},  # wrong length
        {"joints": [[0.1, "x"]]},  # not a number
        {"joints": [[0.1, float("nan")]]},  # NaN
        {},  # missing field
        {"joints": []},  # nothing to do
        {"joints": [[0.1, 0.2], [0.3]]},  # ragged rows
        {"joints": [[0.1, 0.2]] * 10_001},  # more rows than one request may ask for
    ]
    bad_ik = [
        {"tcp": [0, 0, 0]},  # wrong length
        {"tcp": [0, 0, 0, 0, 0, 0, 0]},  # zero quaternion
        {"joints_ref": [0, 0]},  # missing tcp
        {"tcp": [0, 0, 0, 0, 0, 0, 1], "joints_ref": [0]},  # wrong reference length
    ]
    async with (
        running_mock() as (_, url),
        running_server(Settings(ctrlx_url=url)) as base,
        aiohttp.ClientSession() as http,
    ):
        api = f"{base}/api/robots/kin12"
        for body in bad_fk:
            async with http.post(
                api + "/fk", data=_json(body), headers={"content-type": "application/json"}
            ) as resp:
                assert resp.status == 422, body
                assert (await resp.json())["detail"], body
        for body in bad_ik:
            status, answer = await post(http, api + "/ik", body)
            assert status == 422 and answer["detail"], body
        status, answer = await post(http, f"{base}/api/robots/nope/fk", {"joints": [[0, 0]]})
        assert status == 404 and "nope" in answer["detail"]
        status, answer = await post(http, api + "/ik", {"tcp": [5, 5, 0, 0, 0, 0, 1]})
        assert status == 200 and answer["ok"] is False and answer["error"] == "out of reach"


def _json(body: Any) -> str:
    import json

    return json.dumps(body)  # allow_nan: send a literal NaN as a sloppy client would


async def test_fk_with_links_gives_every_link_pose_and_the_tcp_as_the_stream_does() -> None:
    robot = next(r for r in demo_cell().robots if r.name == "iiwa7")
    q = sample_joints("iiwa7", np.random.default_rng(5), 3)
    async with (
        running_mock() as (_, url),
        running_server(Settings(ctrlx_url=url)) as base,
        aiohttp.ClientSession() as http,
    ):
        body = {"joints": q.tolist(), "links": True}
        status, fk = await post(http, f"{base}/api/robots/iiwa7/fk", body)
        too_many = {"joints": [q[0].tolist()] * 65, "links": True}
        status_many, _ = await post(http, f"{base}/api/robots/iiwa7/fk", too_many)
    assert status == 200 and status_many == 422
    links, tcp, _ = robot.poses(q)
    np.testing.assert_allclose(matrix_from_pose7(np.array(fk["links"])), links, atol=1e-12)
    np.testing.assert_allclose(np.array(fk["links"])[:, -1], np.array(fk["tcp"]), atol=1e-12)
    np.testing.assert_allclose(matrix_from_pose7(np.array(fk["tcp"])), tcp, atol=1e-12)


async def test_a_urdf_robot_works_in_fk_and_ik_like_the_others(tmp_path: Path) -> None:
    from server.cell import load_cell
    from server.paths import CELLS_DIR

    cell = load_cell(CELLS_DIR / "examples" / "two_controllers.toml", cache_dir=tmp_path)
    arm = cell.robots[0]
    assert arm.family == "urdf"
    q = np.radians([[10.0, -60.0, 70.0, -40.0, 80.0, 15.0], [-30.0, -100.0, 45.0, 20.0, 60.0, 0.0]])
    async with running_server(Settings(), cell) as base, aiohttp.ClientSession() as http:
        api = f"{base}/api/robots/arm6"
        status, fk = await post(http, api + "/fk", {"joints": q.tolist()})
        assert status == 200 and all(fk["ok"])
        _, expected, _ = arm.poses(q)
        np.testing.assert_allclose(matrix_from_pose7(np.array(fk["tcp"])), expected, atol=1e-12)
        start = (q[0] + 0.2).tolist()
        status, ik = await post(http, api + "/ik", {"tcp": fk["tcp"][0], "joints_ref": start})
    assert status == 200 and ik["ok"], ik
    _, again, _ = arm.poses(np.array(ik["best"]))
    np.testing.assert_allclose(again, expected[0], atol=1e-8)
