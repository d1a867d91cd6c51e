"""/api/history over real sockets: windows equal what the stream sent, sample for sample."""

from __future__ import annotations

import asyncio
import re

import aiohttp
import numpy as np
from websockets.asyncio.client import connect

from server.config import Settings
from server.history import decode_binary
from server.protocol import Frames2, decode_frames
from tests.conftest import running_server


async def stream_frames(base: str, count: int) -> list[Frames2]:
    """``count`` protocol-2 frames messages of the demo source, as a viewer gets them."""
    frames: list[Frames2] = []
    async with connect(base.replace("http", "ws") + "/ws", subprotocols=["linkview.2"]) as ws:
        async with asyncio.timeout(20):
            while len(frames) < count:
                message = await ws.recv()
                if isinstance(message, bytes):
                    frames.append(decode_frames(message))
    return frames


async def test_a_window_equals_what_the_stream_sent_sample_for_sample() -> None:
    async with running_server(Settings()) as base, aiohttp.ClientSession() as http:
        frames = await stream_frames(base, 60)
        frames = frames[10:]  # the first may be the newest kept one, sent on joining
        t_from, t_to = frames[0].t_source, frames[-1].t_source
        query = {"source": "demo", "from": repr(t_from), "to": repr(t_to)}
        async with http.get(f"{base}/api/history", params=query) as response:
            assert response.status == 200
            window = decode_binary(await response.read())
        async with http.get(f"{base}/api/history", params={**query, "format": "json"}) as response:
            as_json = await response.json()
        async with http.get(f"{base}/api/robots") as response:
            names = [r["name"] for r in await response.json()]

    assert window["count"] == len(frames) == as_json["count"]
    assert window["t"].tolist() == [f.t_source for f in frames] == as_json["t"]
    assert window["seq"].tolist() == [f.seq for f in frames]
    for k, frame in enumerate(frames):
        for sent in frame.robots:
            (robot,) = [r for r in window["robots"] if r["index"] == sent.robot_index]
            assert robot["name"] == names[sent.robot_index]
            assert bool(robot["ok"][k]) == sent.ok
            # Joints are the same numbers; poses come from the batch kinematics (f32 on both wires).
            np.testing.assert_array_equal(robot["joints"][k], sent.joints)
            np.testing.assert_allclose(robot["links"][k], sent.links, atol=1e-6, rtol=0)
            np.testing.assert_allclose(robot["tcp"][k], sent.tcp, atol=1e-6, rtol=0)
    for robot, robot_json in zip(window["robots"], as_json["robots"], strict=True):
        np.testing.assert_allclose(robot["joints"], robot_json["joints"], atol=1e-6)
        np.testing.assert_allclose(robot["links"], robot_json["links"], atol=1e-6)


async def test_summary_bounds_and_bad_requests() -> None:
    settings = Settings(history_s=1.0)
    async with running_server(settings) as base, aiohttp.ClientSession() as http:

        async def metric(name: str) -> float:
            async with http.get(f"{base}/metrics") as response:
                text = await response.text()
            return float(re.search(rf'^{name}{{source="demo"}} (\S+)$', text, re.M)[1])  # type: ignore[index]

        await stream_frames(base, 5)
        size = await metric("linkview_history_bytes")
        await asyncio.sleep(2.5)  # longer than the history: it wraps, it does not grow
        assert await metric("linkview_history_bytes") == size
        capacity = int(np.ceil(1.0 / 0.02 * 1.25))
        assert 40 <= await metric("linkview_history_samples") <= capacity
        async with http.get(f"{base}/api/history") as response:
            summary = await response.json()
        (source,) = summary["sources"]
        assert source["name"] == "demo" and source["samples"] <= capacity
        async with http.get(f"{base}/api/history", params={"source": "nope"}) as response:
            assert response.status == 404
        params = {"source": "demo", "from": "10", "to": "5"}
        async with http.get(f"{base}/api/history", params=params) as response:
            assert response.status == 422
        async with http.get(f"{base}/api/history", params={"source": "demo", "poses": "x"}) as r:
            assert r.status == 422
