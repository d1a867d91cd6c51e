"""Moves commanded through the server: the embedded mock's robot gets there; others refuse."""

from __future__ import annotations

import asyncio
import json
from typing import Any

import aiohttp
import numpy as np
from websockets.asyncio.client import connect

from server.config import Settings
from tests.conftest import running_mock, running_server


async def post(base: str, path: str, body: Any) -> tuple[int, Any]:
    async with aiohttp.ClientSession() as http, http.post(base + path, json=body) as resp:
        return resp.status, await resp.json()


async def newest_joints(base: str, robot: str) -> list[float]:
    async with connect(base.replace("http", "ws") + "/ws") as ws, asyncio.timeout(10):
        while True:
            message = json.loads(await ws.recv())
            if message["type"] == "frame" and message["robot"] == robot and message["ok"]:
                joints: list[float] = message["joints"]
                return joints


async def test_a_move_brings_the_mocks_robot_to_the_target() -> None:
    target = np.radians([20.0, -10.0, 15.0, -70.0, 10.0, 40.0, 5.0])
    async with running_server(Settings()) as base:
        status, answer = await post(base, "/api/robots/iiwa7/move", {"joints": target.tolist()})
        assert status == 202 and answer["ok"] is True
        async with asyncio.timeout(20):
            while not np.allclose(await newest_joints(base, "iiwa7"), target, atol=1e-9):
                await asyncio.sleep(0.1)


async def test_the_mock_holds_the_target_as_long_as_hello_says_then_resumes_its_cycle() -> None:
    target = np.radians([20.0, -10.0, 15.0, -70.0, 10.0, 40.0, 5.0])
    async with running_server(Settings(mock_hold_s=1.5)) as base:
        async with aiohttp.ClientSession() as http, http.get(base + "/api/robots") as resp:
            robots = await resp.json()
        assert [r["hold_s"] for r in robots] == [1.5, 1.5, 1.5]
        status, _ = await post(base, "/api/robots/iiwa7/move", {"joints": target.tolist()})
        assert status == 202
        async with asyncio.timeout(20):
            while not np.allclose(await newest_joints(base, "iiwa7"), target, atol=1e-9):
                await asyncio.sleep(0.1)
        async with asyncio.timeout(20):  # the hold ends: the demo cycle takes the robot away
            while np.allclose(await newest_joints(base, "iiwa7"), target, atol=1e-3):
                await asyncio.sleep(0.1)


async def test_moves_outside_the_limits_or_of_the_wrong_size_are_refused() -> None:
    async with running_server(Settings()) as base:
        status, answer = await post(base, "/api/robots/kin12/move", {"joints": [1.0, 0.0]})
        assert status == 422 and "outside the joint limits: a0" in answer["detail"]
        status, answer = await post(base, "/api/robots/kin12/move", {"joints": [0.1]})
        assert status == 422 and "2 finite joint values" in answer["detail"]
        status, _ = await post(base, "/api/robots/nobody/move", {"joints": [0.1]})
        assert status == 404


async def test_a_real_controller_is_never_moved_without_allow_commands() -> None:
    async with running_mock() as (app, url), running_server(Settings(ctrlx_url=url)) as base:
        status, answer = await post(base, "/api/robots/kin12/move", {"joints": [0.1, 0.1]})
        assert status == 403 and "--allow-commands" in answer["detail"]
        async with aiohttp.ClientSession() as http, http.get(base + "/api/robots") as resp:
            robots = await resp.json()
        assert [r["commandable"] for r in robots] == [False, False, False]
        assert [r["hold_s"] for r in robots] == [None, None, None]  # a controller holds nothing
    async with (
        running_mock() as (app, url),
        running_server(Settings(ctrlx_url=url, allow_commands=True)) as base,
    ):
        status, _ = await post(base, "/api/robots/kin12/move", {"joints": [0.1, 0.1]})
        assert status == 202
