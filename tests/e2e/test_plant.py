"""The example plant (an iiwa over OPC UA, a Type 12 over ctrlX, a UR5e and a MotionPlus
positioner over RTDE, a Type 12 over MQTT) through the whole server."""

from __future__ import annotations

import json
from pathlib import Path

import aiohttp
import pytest

from server.config import Settings
from tests.conftest import running_server
from tests.e2e.test_faults import wait_for_robots
from tests.e2e.test_recording import read

ROOT = Path(__file__).resolve().parents[2]
PLANT = ROOT / "cells" / "examples" / "plant.toml"
ROBOTS = ("iiwa7", "kin12", "ur5e", "positioner", "feeder")


async def test_the_plant_streams_every_robot_records_and_replays(
    tmp_path: Path, opcua_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("LINKVIEW_CACHE_DIR", str(opcua_cache))  # the OPC UA mock's address space
    async with running_server(Settings(cell=PLANT)) as base, aiohttp.ClientSession() as http:
        health = await wait_for_robots(base, ROBOTS, 300, timeout_s=90)  # both, for a while
        kinds = {s["name"]: s["url"].split(":", 1)[0] for s in health["sources"]}
        assert kinds == {"kuka": "opc.tcp", "ctrlx": "http", "ur": "rtde", "broker": "mqtt"}
        async with http.post(f"{base}/api/history/recording", json={"minutes": 1}) as r:
            assert r.status == 200
            saved = tmp_path / "saved.mcap"
            saved.write_bytes(await r.read())
    _, messages = read(saved)
    # Over the time both streamed (the OPC UA mock starts with the first session).
    times = {robot: [t for t, _ in messages[f"/{robot}/joints"]] for robot in ROBOTS}
    start, end = max(t[0] for t in times.values()), min(t[-1] for t in times.values())
    counts = {robot: sum(start <= t <= end for t in times[robot]) for robot in ROBOTS}
    # All at the frame cadence of the ctrlX source (50 Hz), over the same time: the OPC UA
    # source's one subscription publishes every 20 ms, as the ctrlX mock's event stream does;
    # RTDE's 500 Hz come out at 50 Hz (not ten times as many); the embedded broker's
    # publisher may fall behind on a loaded machine, never ahead.
    assert 0.75 < counts["iiwa7"] / counts["kin12"] < 1.25, counts
    for robot in ("ur5e", "positioner", "feeder"):
        assert 0.6 < counts[robot] / counts["kin12"] < 1.25, counts
    stamps = [json.loads(data)["t_source"] for _, data in messages["/iiwa7/joints"]]
    # Never older than the one before; a repeat is the device's last values held at rest.
    assert all(b >= a for a, b in zip(stamps, stamps[1:], strict=False))
    assert len(set(stamps)) > len(stamps) / 2
    ur = [json.loads(data)["t_source"] for _, data in messages["/ur5e/joints"]]
    assert all(b > a for a, b in zip(ur, ur[1:], strict=False))  # no RTDE package twice

    async with running_server(Settings(replay=saved, cell=PLANT)) as base:
        health = await wait_for_robots(base, ROBOTS, 10)
        assert {s["url"] for s in health["sources"]} == {"replay:saved.mcap"}
