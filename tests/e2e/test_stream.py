"""End to end over real sockets: mock data layer -> server -> WebSocket viewer."""

from __future__ import annotations

import asyncio
import cmath
import json
import math
from typing import Any

import aiohttp
import pytest
from websockets.asyncio.client import connect

from server.config import Settings
from server.mock_ctrlx import STATE_KEY, Machine, build_app
from server.protocol import Frame, Hello, Status
from tests.conftest import running_mock, running_server

TYPE12_MM = {"L1": 200.0, "L2": 150.0, "L3": 100.0, "L4": 200.0, "L5": 100.0}


def seed_tcp_mm(a0_deg: float, a1_deg: float) -> tuple[float, float]:
    """Seed 000 AxesToCartesian in millimetres and degrees, written independently of server code.

    E is found as the complex-plane intersection of circles (T, L3) and (W, L4)
    on the seed's right-hand branch; then TCP = T + (E - T) * L2 / L3.
    """
    L = TYPE12_MM
    t = L["L1"] * cmath.exp(1j * math.radians(a0_deg + 180))
    w = L["L5"] * cmath.exp(1j * math.radians(a1_deg + 270))
    d = abs(w - t)
    cos_t = (d * d + L["L3"] ** 2 - L["L4"] ** 2) / (2 * d * L["L3"])
    toward = (w - t) / d * L["L3"]
    e = t + toward * complex(cos_t, -math.sqrt(1 - cos_t * cos_t))  # rotate by -theta
    tcp = t + (e - t) * L["L2"] / L["L3"]
    return tcp.real, tcp.imag


async def read_messages(url: str, count: int, robot: str | None = None) -> list[dict[str, Any]]:
    """Messages a viewer receives until ``count`` of them (or of ``robot``'s frames) arrived."""
    out: list[dict[str, Any]] = []
    seen = 0
    async with connect(url) as ws:
        async with asyncio.timeout(15):
            while seen < count:
                out.append(json.loads(await ws.recv()))
                seen += robot is None or out[-1].get("robot") == robot
    return out


POSES_DEG = [(12.5, -17.0), (-22.0, 8.0)]
"""Where the test commands the mock's Type 12 (a0, a1 in degrees, as the data layer serves
them): poses of its own choosing, not the mock's demo targets."""
FRAMES_PER_POSE = 10


async def frames_at(
    ws: Any, machine: Machine, pose_deg: tuple[float, float], seen: list[dict[str, Any]]
) -> list[Frame]:
    """Commands ``pose_deg``; kin12's frames sampled once the mock stands there (every
    message read goes to ``seen``)."""
    settled = machine.now() + machine.command("kin12", pose_deg) + machine.lag_s + 0.05
    frames: list[Frame] = []
    while len(frames) < FRAMES_PER_POSE:
        message = json.loads(await ws.recv())
        seen.append(message)
        if message["type"] == "frame" and message["robot"] == "kin12":
            frame = Frame.model_validate(message)
            if frame.t_source > settled:
                frames.append(frame)
    return frames


async def test_viewer_gets_hello_then_frames_matching_seed_formula() -> None:
    app = build_app()
    machine = app[STATE_KEY].machine
    async with (
        running_mock(app) as (_, mock_url),
        running_server(Settings(ctrlx_url=mock_url)) as base,
        connect(base.replace("http", "ws") + "/ws") as ws,
    ):
        async with asyncio.timeout(30):
            messages = [json.loads(await ws.recv())]
            posed = {pose: await frames_at(ws, machine, pose, messages) for pose in POSES_DEG}

    hello = Hello.model_validate(messages[0])
    assert hello.protocol == 1
    (robot,) = [r for r in hello.robots if r.name == "kin12"]
    assert robot.kinematics == "type12"
    assert [j.name for j in robot.joints] == ["a0", "a1"]
    assert robot.params["L1"] == 0.2
    statuses = [Status.model_validate(m) for m in messages[1:] if m["type"] == "status"]
    assert statuses and statuses[-1].sources[0].state == "connected"

    for (a0, a1), frames in posed.items():
        # The expected values come from the commanded degrees alone, never from the frame.
        x_mm, y_mm = seed_tcp_mm(a0, a1)
        assert [f.seq for f in frames] == sorted({f.seq for f in frames})
        for frame in frames:
            assert frame.ok and frame.error is None
            assert frame.joints == pytest.approx([math.radians(a0), math.radians(a1)], abs=1e-12)
            assert math.isclose(frame.tcp[0] * 1000, x_mm, abs_tol=1e-9)
            assert math.isclose(frame.tcp[1] * 1000, y_mm, abs_tol=1e-9)
            assert frame.tcp[2] == 0.0
            assert len(frame.links) == len(robot.links)
            for pose in frame.links:
                assert math.isclose(sum(c * c for c in pose[3:]), 1.0, rel_tol=1e-12)
            assert frame.t_source <= frame.t_sent


async def test_health_reports_connected_source_and_sample_age() -> None:
    async with (
        running_mock() as (_, mock_url),
        running_server(Settings(ctrlx_url=mock_url)) as base,
        aiohttp.ClientSession() as http,
    ):
        async with asyncio.timeout(10):
            while True:
                async with http.get(base + "/api/health") as resp:
                    health = await resp.json()
                    connected = health["sources"][0]["state"] == "connected"
                    assert resp.status == (200 if connected else 503)  # 503: no source live
                if connected:
                    break
                await asyncio.sleep(0.05)
    source = health["sources"][0]
    assert source["url"] == mock_url
    assert source["error"] is None
    assert 0.0 <= source["last_sample_age_s"] < 5.0
    assert health["status"] == "ok"


async def test_page_and_meshes_are_served() -> None:
    async with (
        running_mock() as (_, mock_url),
        running_server(Settings(ctrlx_url=mock_url)) as base,
        aiohttp.ClientSession() as http,
    ):
        async with http.get(base + "/") as resp:
            assert resp.status == 200
            assert "importmap" in await resp.text()
        hello = (await read_messages(base.replace("http", "ws") + "/ws", 1))[0]
        for robot in hello["robots"]:
            for link in robot["links"]:
                async with http.get(base + link["mesh"]) as resp:
                    assert resp.status == 200, link["mesh"]
                    assert (await resp.read())[:4] == b"glTF"
