"""RTDE and MQTT sources through the whole server: health and the page's status (the
example plant, with both, records and replays: tests/e2e/test_plant.py)."""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import aiohttp
import aiomqtt
import numpy as np
import pytest
from websockets.asyncio.client import connect

from server.config import Settings
from server.mock_ctrlx import Machine
from server.mock_rtde import RtdeMock, demo_groups
from server.mqtt import Mosquitto
from tests.conftest import free_port, running_server
from tests.e2e.test_faults import health_of, wait_for_health

UR5E_DH = (
    'kinematics = { type = "dh", d = [162.5, 0.0, 0.0, 133.3, 99.7, 99.6], '
    "a = [0.0, -425.0, -392.2, 0.0, 0.0, 0.0], alpha_deg = [90.0, 0.0, 0.0, 90.0, -90.0, 0.0] }"
)
TWO_AXES = """[robot.kinematics]
type = "axis_group"
axes = [{{ name = "tilt" }}, {{ name = "turn", parent = "tilt" }}]
"""


def rtde_cell(folder: Path, url: str) -> Path:
    """A UR5e (no joint list), the positioner on registers 42/43, and one on a missing register."""
    path = folder / "ur.toml"
    path.write_text(
        f"""
[[source]]
name = "ur"
type = "rtde"
url = "{url}"

[[robot]]
name = "ur5e"
source = "ur"
{UR5E_DH}

[[robot]]
name = "positioner"
source = "ur"
joints = [{{ register = 42 }}, {{ field = "output_double_register_43" }}]
{TWO_AXES.format()}
[[robot]]
name = "lost"
source = "ur"
joints = [{{ register = 42 }}, {{ register = 60 }}]
{TWO_AXES.format()}"""
    )
    return path


@pytest.fixture
async def ur() -> AsyncIterator[RtdeMock]:
    mock = RtdeMock(Machine(demo_groups()))
    await mock.start("127.0.0.1", free_port())
    try:
        yield mock
    finally:
        await mock.close()


def source(health: dict[str, Any], name: str) -> dict[str, Any]:
    found: dict[str, Any] = next(s for s in health["sources"] if s["name"] == name)
    return found


async def status_on_the_page(base: str, name: str, wanted: str) -> dict[str, Any]:
    """The first ``status`` message for source ``name`` whose device text contains ``wanted``."""
    async with connect(base.replace("http", "ws") + "/ws") as ws, asyncio.timeout(10):
        while True:
            msg = json.loads(await ws.recv())
            for status in msg.get("sources", []) if msg["type"] == "status" else []:
                if status["name"] == name and wanted in (status.get("device") or ""):
                    return dict(status)


async def test_a_ur_controller_through_the_server(tmp_path: Path, ur: RtdeMock) -> None:
    settings = Settings(cell=rtde_cell(tmp_path, ur.url))
    async with running_server(settings) as base:
        health = await wait_for_health(
            base, lambda h: source(h, "ur")["robots"].get("ur5e", {}).get("frames", 0) > 20
        )
        ur_source = source(health, "ur")
        assert ur_source["device"] == "URControl 5.15.0.0: robot mode RUNNING, safety mode NORMAL"
        robots = ur_source["robots"]
        assert robots["ur5e"]["ok"] and robots["positioner"]["ok"]
        # The register the controller lacks is named on its robot only.
        assert not robots["lost"]["ok"]
        assert "output_double_register_60" in robots["lost"]["error"]
        assert "NOT_FOUND" in robots["lost"]["error"]

        # The joints the page gets are the controller's actual_q (radians, in UR's order).
        async with aiohttp.ClientSession() as http, http.get(f"{base}/api/robots") as r:
            ur5e = next(x for x in await r.json() if x["name"] == "ur5e")
        assert [j["node"] for j in ur5e["joints"]] == [f"actual_q[{i}]" for i in range(6)]
        assert [j["setpoint"] for j in ur5e["joints"]] == [f"target_q[{i}]" for i in range(6)]
        assert {j["source_unit"] for j in ur5e["joints"]} == {"rad"}

        # A protective stop shows in health and in the source's status the page draws.
        ur.protective_stop()
        await wait_for_health(base, lambda h: "PROTECTIVE" in (source(h, "ur")["device"] or ""))
        status = await status_on_the_page(base, "ur", "PROTECTIVE_STOP")
        assert status["device"].endswith("robot mode RUNNING, safety mode PROTECTIVE_STOP")
        assert status["halted"] == "protective stop"
        assert source(await health_of(base), "ur")["halted"] == "protective stop"
        ur.protective_stop(False)
        await wait_for_health(base, lambda h: source(h, "ur")["halted"] is None)

        # Dropped: streaming again within 2 s of the controller taking connections again.
        before = source(await health_of(base), "ur")["robots"]["ur5e"]["frames"]
        ur.drop(down_s=0.5)
        back_at = time.monotonic() + 0.5
        await wait_for_health(
            base, lambda h: source(h, "ur")["robots"]["ur5e"]["frames"] > before + 25
        )
        assert time.monotonic() - back_at < 2.0


def mqtt_cell(folder: Path, url: str) -> Path:
    path = folder / "mqtt.toml"
    path.write_text(
        f"""
[[source]]
name = "broker"
type = "mqtt"
url = "{url}"

[[robot]]
name = "table"
source = "broker"
joints = [{{ node = "cell/table/tilt", unit = "deg" }}, {{ node = "cell/table/state#/turn" }}]
{TWO_AXES.format()}"""
    )
    return path


async def test_a_malformed_payload_is_named_in_health_and_a_good_one_streams(
    tmp_path: Path,
) -> None:
    broker = Mosquitto(port=free_port())
    await broker.start()
    try:
        settings = Settings(cell=mqtt_cell(tmp_path, broker.url))
        async with running_server(settings) as base:
            async with aiomqtt.Client(broker.host, broker.port) as client:

                async def send(tilt: bytes) -> None:
                    await client.publish("cell/table/tilt", tilt)
                    await client.publish("cell/table/state", b'{"turn": 90.0}')

                async def robot() -> dict[str, Any]:
                    health = await health_of(base)
                    table: dict[str, Any] = source(health, "broker")["robots"].get("table", {})
                    return table

                async with asyncio.timeout(15):
                    while "not a number" not in ((await robot()).get("error") or ""):
                        await send(b"12,5")
                        await asyncio.sleep(0.05)
                    error = (await robot())["error"]
                    assert "cell/table/tilt: payload '12,5' is not a number" in error
                    while not (await robot()).get("ok"):
                        await send(b"12.5")
                        await asyncio.sleep(0.05)
            async with aiohttp.ClientSession() as http, http.get(f"{base}/api/robots") as r:
                (table,) = await r.json()
            # The newest raw values, and in SI: degrees by the cell's default unit.
            assert [j["value"] for j in table["joints"]] == [12.5, 90.0]
            si = [j["value_si"] for j in table["joints"]]
            np.testing.assert_allclose(si, np.radians([12.5, 90.0]))
    finally:
        await broker.close()


async def test_sparkplug_metrics_of_the_embedded_mock_pose_a_robot(tmp_path: Path) -> None:
    # No url: Mosquitto and a publisher acting as a Sparkplug B edge node (births, then
    # data by alias), read back by the same connector that reads a plant's broker.
    cell = tmp_path / "sparkplug.toml"
    device = "spBv1.0/Plant/Cell1/Table"
    cell.write_text(
        f"""
[[source]]
name = "edge"
type = "mqtt"

[[robot]]
name = "table"
source = "edge"
joints = [{{ node = "{device}#Axis 1/Position", unit = "deg" }},
          {{ node = "{device}#Axis 2/Position", unit = "deg" }}]
{TWO_AXES.format()}"""
    )
    async with running_server(Settings(cell=cell)) as base:
        health = await wait_for_health(
            base, lambda h: source(h, "edge")["robots"].get("table", {}).get("frames", 0) > 10
        )
        table = source(health, "edge")["robots"]["table"]
        assert table["ok"] and table["error"] is None, table
        assert source(health, "edge")["state"] == "connected"
