"""Bad input never crashes the server or stops the other robots; it is reported clearly."""

from __future__ import annotations

import asyncio
import json
import logging
from typing import Any

import aiohttp
import pytest
from pydantic import SecretStr
from websockets.asyncio.client import connect

from server.cell import Joint, Robot
from server.config import Settings
from server.kinematics import Type12
from server.mock_ctrlx import build_app, serve
from tests.conftest import cell_with, free_port, running_mock, running_server


async def health_of(base: str) -> dict[str, Any]:
    async with aiohttp.ClientSession() as http, http.get(base + "/api/health") as resp:
        assert resp.status in (200, 503)  # 503: no source is live
        result: dict[str, Any] = await resp.json()
        return result


async def wait_for_health(base: str, predicate: Any, timeout_s: float = 15.0) -> dict[str, Any]:
    async with asyncio.timeout(timeout_s):
        while not predicate(health := await health_of(base)):
            await asyncio.sleep(0.05)
    return health


async def wait_for_robots(
    base: str, robots: tuple[str, ...], frames: int, timeout_s: float = 15.0
) -> dict[str, Any]:
    """Health once every one of ``robots`` (and no other) has made more than ``frames``."""

    def made(health: dict[str, Any]) -> bool:
        seen = {name: r for s in health["sources"] for name, r in s["robots"].items()}
        return set(seen) == set(robots) and all(r.get("frames", 0) > frames for r in seen.values())

    return await wait_for_health(base, made, timeout_s)


async def latest_frames(base: str, robots: set[str]) -> dict[str, dict[str, Any]]:
    """The first frame of each robot in ``robots`` a fresh viewer sees."""
    seen: dict[str, dict[str, Any]] = {}
    async with connect(base.replace("http", "ws") + "/ws") as ws, asyncio.timeout(10):
        while set(seen) != robots:
            msg = json.loads(await ws.recv())
            if msg["type"] == "frame" and msg["robot"] in robots:
                seen[msg["robot"]] = msg
    return seen


def robot_on(name: str, kin: Type12, axes: tuple[str, str]) -> Robot:
    joints = tuple(
        Joint(j, f"motion/axs/{a}/state/values/actual/pos", "deg")
        for j, a in zip(("a0", "a1"), axes, strict=True)
    )
    return Robot(
        name=name, family="type12", kinematics=kin, joints=joints, link_names=kin.link_names
    )


async def test_wrong_password_is_reported_and_server_keeps_serving() -> None:
    settings_ok = Settings(ctrlx_password=SecretStr("wrong"))
    async with (
        running_mock() as (_, url),
        running_server(settings_ok.model_copy(update={"ctrlx_url": url})) as base,
    ):
        health = await wait_for_health(base, lambda h: h["sources"][0]["state"] == "error")
        error = health["sources"][0]["error"]
        assert "401" in error and "wrong user name or password" in error
        assert "wrong" not in error.replace("wrong user", ""), "the password must not leak"
        assert health["status"] == "degraded"
        async with connect(base.replace("http", "ws") + "/ws") as ws, asyncio.timeout(10):
            hello = json.loads(await ws.recv())
            assert hello["type"] == "hello"
            notice = json.loads(await ws.recv())
            assert notice["type"] == "cell" and notice["error"] is None
            status = json.loads(await ws.recv())
            assert status["type"] == "status" and status["sources"][0]["state"] == "error"


async def test_unknown_node_spoils_only_its_robot() -> None:
    ghost = robot_on("ghost", Type12(), ("kin12_a0", "no_such_axis"))
    async with (
        running_mock() as (_, url),
        running_server(Settings(ctrlx_url=url), cell_with(ghost)) as base,
    ):
        frames = await latest_frames(base, {"kin12", "ghost"})
        health = await wait_for_health(
            base, lambda h: h["sources"][0]["robots"].get("ghost", {}).get("frames", 0) > 0
        )
    assert frames["kin12"]["ok"] is True
    assert frames["ghost"]["ok"] is False
    assert "404" in frames["ghost"]["error"] and "no_such_axis" in frames["ghost"]["error"]
    assert frames["ghost"]["links"] == []
    assert health["sources"][0]["state"] == "connected"
    assert "DL_INVALID_ADDRESS" in health["sources"][0]["robots"]["ghost"]["error"]
    assert health["sources"][0]["robots"]["kin12"]["ok"] is True


async def test_unreachable_posture_gives_error_frames_not_nan() -> None:
    # With L4 far too short the bar cannot close the loop at any of the mock's angles.
    broken = robot_on("broken", Type12(l4=0.01), ("kin12_a0", "kin12_a1"))
    async with (
        running_mock() as (_, url),
        running_server(Settings(ctrlx_url=url), cell_with(broken)) as base,
    ):
        frames = await latest_frames(base, {"kin12", "broken"})
    assert frames["kin12"]["ok"] is True
    assert frames["broken"]["ok"] is False
    assert frames["broken"]["error"].startswith("unreachable posture")
    assert len(frames["broken"]["joints"]) == 2
    assert frames["broken"]["links"] == [] and frames["broken"]["tcp"] == []


async def test_data_layer_down_then_up_recovers() -> None:
    # The controller streams, goes away (its port refuses), and comes back on the same port.
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    runner, _ = await serve(build_app(), "127.0.0.1", port)
    try:
        async with running_server(Settings(ctrlx_url=url)) as base:
            await wait_for_health(base, lambda h: h["sources"][0]["state"] == "connected")
            before = await latest_frames(base, {"kin12"})
            await runner.cleanup()  # down
            down = await wait_for_health(
                base,
                lambda h: h["sources"][0]["error"] == f"cannot reach {url}: connection refused",
                timeout_s=30,
            )
            runner, _ = await serve(build_app(), "127.0.0.1", port)  # up again
            health = await wait_for_health(
                base, lambda h: h["sources"][0]["state"] == "connected", timeout_s=30
            )
            after = await latest_frames(base, {"kin12"})
    finally:
        await runner.cleanup()
    assert before["kin12"]["ok"] is True
    assert down["sources"][0]["state"] == "error" and down["status"] == "degraded"
    assert health["sources"][0]["error"] is None
    assert after["kin12"]["ok"] is True
    assert after["kin12"]["seq"] > before["kin12"]["seq"], "the same source streams on"


async def test_passwords_and_tokens_never_reach_the_log(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG)
    secret = "Sup3r-s3cret-pw"
    async with running_mock() as (_, url):
        bad = Settings(ctrlx_url=url, ctrlx_password=SecretStr(secret))
        async with running_server(bad) as base:
            await wait_for_health(base, lambda h: h["sources"][0]["state"] == "error")
        async with running_server(Settings(ctrlx_url=url)) as base:
            await wait_for_health(base, lambda h: h["sources"][0]["state"] == "connected")
            await latest_frames(base, {"kin12"})
    text = "\n".join(r.getMessage() for r in caplog.records)
    assert "logged in" in text or "subscri" in text, "the log should say what happened"
    assert "401" in text
    for leak in (secret, 'boschrexroth"', "password=boschrexroth", "eyJ"):  # eyJ: a JWT
        assert leak not in text


class Exploding:
    """Kinematics with a bug: every call raises."""

    def link_poses(self, q: Any) -> Any:
        raise RuntimeError("kinematics bug")

    forward = link_poses

    def params(self) -> dict[str, Any]:
        return {}


async def test_a_robot_whose_kinematics_raises_does_not_stop_the_others() -> None:
    buggy = Robot(
        name="buggy",
        family="type12",
        kinematics=Exploding(),  # type: ignore[arg-type]
        joints=robot_on("x", Type12(), ("kin12_a0", "kin12_a1")).joints,
        link_names=("L1",),
    )
    async with (
        running_mock() as (_, url),
        running_server(Settings(ctrlx_url=url), cell_with(buggy)) as base,
    ):
        first = await latest_frames(base, {"kin12", "buggy"})
        later = first
        async with asyncio.timeout(10):  # a fresh viewer may first get the same newest frame
            while later["kin12"]["seq"] <= first["kin12"]["seq"]:
                later = await latest_frames(base, {"kin12", "buggy"})
    assert first["buggy"]["ok"] is False and "kinematics bug" in first["buggy"]["error"]
    assert first["kin12"]["ok"] is True and later["kin12"]["ok"] is True
    assert later["kin12"]["seq"] > first["kin12"]["seq"], "the stream must go on"
    assert later["buggy"]["ok"] is False


async def test_binary_messages_from_a_viewer_are_ignored() -> None:
    async def kin12_seqs(ws: Any, count: int) -> list[int]:
        seqs: list[int] = []
        while len(seqs) < count:
            msg = json.loads(await ws.recv())
            if msg["type"] == "frame" and msg["robot"] == "kin12":
                seqs.append(msg["seq"])
        return seqs

    async with running_mock() as (_, url), running_server(Settings(ctrlx_url=url)) as base:
        async with connect(base.replace("http", "ws") + "/ws") as ws, asyncio.timeout(20):
            (before,) = await kin12_seqs(ws, 1)
            await ws.send(b"\x00\x01 not text")
            await ws.send("some text")
            await ws.send(bytes(range(256)) * 8)
            after = await kin12_seqs(ws, 20)
            health = await health_of(base)
            assert ws.close_code is None, "the viewer was disconnected"
    # The stream went on, in order, to a viewer the server still counts.
    assert before < after[0] and after == sorted(set(after)), (before, after)
    assert health["viewers"] == 1
