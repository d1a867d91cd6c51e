"""Clearance: the nearest links of different robots, measured on their meshes (python-fcl).

Two upright KUKA LBR iiwa arms side by side: their bases are the widest links
(0.11 m around the axis), so the nearest pair is base to base, ``apart - 0.22`` m
apart. The demo cell's own motion, as the embedded mock plays it, must keep
every robot clear of the others.
"""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import aiohttp
import numpy as np
import pytest
from websockets.asyncio.client import connect

from server.cell import Robot, load_cell
from server.clearance import ClearanceChecker, Near, link_shapes
from server.config import Settings
from server.kinematics import matrix_from_pose7
from server.mock_ctrlx.machine import Machine
from server.paths import DEMO_CELL
from tests.clearance.cells import BASE_RADIUS_M, two_arms
from tests.conftest import running_server


def world_links(robot: Robot, q: np.ndarray) -> np.ndarray:
    links, ok = robot.kinematics.link_poses(q)
    assert ok.all()
    world: np.ndarray = matrix_from_pose7(np.asarray(robot.base)) @ links
    return world


def measure(folder: Path, apart_m: float, within_m: float) -> list[Near]:
    cell = load_cell(two_arms(folder, apart_m))
    checker = ClearanceChecker({r.name: link_shapes(r) for r in cell.robots})
    upright = np.zeros(7)
    return checker.check({r.name: world_links(r, upright) for r in cell.robots}, within_m)


@pytest.mark.parametrize("apart_m", [0.25, 0.3, 0.4])
def test_two_arms_apart_are_nearest_at_their_bases(tmp_path: Path, apart_m: float) -> None:
    (near,) = measure(tmp_path, apart_m, within_m=0.5)
    assert (near.robot_a, near.link_a, near.robot_b, near.link_b) == ("left", 0, "right", 0)
    assert near.distance_m == pytest.approx(apart_m - 2 * BASE_RADIUS_M, abs=1e-6)


def test_arms_that_interpenetrate_touch(tmp_path: Path) -> None:
    (near,) = measure(tmp_path, 0.15, within_m=0.05)
    assert (near.robot_a, near.robot_b) == ("left", "right")
    assert near.distance_m == 0.0


def test_arms_further_apart_than_asked_are_not_reported(tmp_path: Path) -> None:
    assert measure(tmp_path, 0.3, within_m=0.07) == []  # 0.08 m apart
    assert measure(tmp_path, 2.0, within_m=0.05) == []  # skipped by their boxes


def test_the_demo_cycle_keeps_every_robot_clear() -> None:
    cell = load_cell(DEMO_CELL)
    checker = ClearanceChecker({r.name: link_shapes(r) for r in cell.robots})
    assert set(checker.robots) == {"kin12", "iiwa7", "positioner"}
    machine = Machine(clock=lambda: 0.0)

    def joints(robot: Robot, snapshot: dict[str, float]) -> np.ndarray:
        axes = [next(a for a in machine.axes if f"/{a}/" in node) for node in robot.nodes]
        q: np.ndarray = robot.to_si(np.array([snapshot[a] for a in axes]))
        return q

    closest = np.inf
    for t in np.arange(0.0, 120.0, 0.1):  # every demo cycle several times over
        snapshot = machine.snapshot(float(t))
        world = {r.name: world_links(r, joints(r, snapshot)) for r in cell.robots}
        for near in checker.check(world, within_m=0.05):
            closest = min(closest, near.distance_m)
    assert closest == np.inf, f"robots of the demo cell come within {closest:.3f} m"


async def next_clearance(base: str) -> dict[str, Any]:
    """The first clearance message that measured both arms, once a page asked for it."""
    async with connect(base.replace("http", "ws") + "/ws") as ws, asyncio.timeout(20):
        await asyncio.sleep(0.5)
        async with aiohttp.ClientSession() as http:
            async with http.get(base + "/api/health") as resp:
                assert resp.status in (200, 503)
            # Nobody asked yet: nothing was measured, nothing sent.
            async with http.post(base + "/api/clearance", json={}) as resp:
                assert resp.status == 204
        while True:
            message = await ws.recv()
            if isinstance(message, str) and json.loads(message)["type"] == "clearance":
                found: dict[str, Any] = json.loads(message)
                if found["robots"]:  # once both arms have a pose
                    return found


async def test_viewers_are_told_which_links_touch(tmp_path: Path) -> None:
    async with running_server(Settings(cell=two_arms(tmp_path, 0.15))) as base:
        clearance = await next_clearance(base)
    assert clearance["within_m"] == 0.05 and sorted(clearance["robots"]) == ["left", "right"]
    (near,) = clearance["near"]
    assert near["robots"] == ["left", "right"] and near["distance_m"] == 0.0
    assert near["link_names"] == ["link0", "link0"]


async def test_viewers_hear_of_no_pair_when_robots_are_clear(tmp_path: Path) -> None:
    settings = Settings(cell=two_arms(tmp_path, 0.3), clearance_m=0.05)
    async with running_server(settings) as base:
        clearance = await next_clearance(base)
    assert clearance["near"] == [] and sorted(clearance["robots"]) == ["left", "right"]


async def test_nothing_is_measured_until_a_page_asks(tmp_path: Path) -> None:
    async with running_server(Settings(cell=two_arms(tmp_path, 0.15))) as base:
        async with connect(base.replace("http", "ws") + "/ws") as ws:
            types = []
            try:
                async with asyncio.timeout(1.5):
                    while True:
                        message = await ws.recv()
                        if isinstance(message, str):
                            types.append(json.loads(message)["type"])
            except TimeoutError:
                pass
    assert "status" in types and "clearance" not in types, types
