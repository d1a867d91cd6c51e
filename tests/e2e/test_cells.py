"""Cells over real sockets: several controllers, one of them down, and reloading the file."""

from __future__ import annotations

import asyncio
import json
import textwrap
from pathlib import Path
from typing import Any

import aiohttp
from websockets.asyncio.client import ClientConnection, connect

from server.cell import load_cell
from server.config import Settings
from tests.conftest import free_port, running_server

ARM = """
[[robot]]
name = "{name}"
source = "{source}"
base = {{ xyz = [{x}, 0.0, 0.0] }}
kinematics = {{ type = "type12", limits = [[-40.0, 40.0], [-40.0, 40.0]] }}
joints = [ {{ node = "motion/axs/{name}_a/state/values/actual/pos" }},
           {{ node = "motion/axs/{name}_b/state/values/actual/pos" }} ]
"""


def cell_text(sources: str, *robots: tuple[str, str, float]) -> str:
    body = "".join(ARM.format(name=n, source=s, x=x) for n, s, x in robots)
    return textwrap.dedent(sources) + body


TWO_MOCKS = """
[[source]]
name = "line1"

[[source]]
name = "line2"
"""


async def health(base: str) -> dict[str, Any]:
    async with aiohttp.ClientSession() as http, http.get(base + "/api/health") as resp:
        result: dict[str, Any] = await resp.json()
        return result


async def next_of(ws: ClientConnection, kind: str, robot: str | None = None) -> dict[str, Any]:
    async with asyncio.timeout(15):
        while True:
            message = json.loads(await ws.recv())
            if message["type"] == kind and (robot is None or message.get("robot") == robot):
                return message  # type: ignore[no-any-return]


async def test_two_controllers_one_down_the_other_keeps_streaming(tmp_path: Path) -> None:
    dead = f"http://127.0.0.1:{free_port()}"
    sources = f"""
    [[source]]
    name = "line1"

    [[source]]
    name = "line2"
    url = "{dead}"
    password_env = "LINE2_PW"
    """
    path = tmp_path / "cell.toml"
    path.write_text(cell_text(sources, ("up", "line1", 0.0), ("down", "line2", 500.0)))
    cell = load_cell(path, env={"LINE2_PW": "x"})
    async with running_server(Settings(), cell) as base:
        async with connect(base.replace("http", "ws") + "/ws") as ws:
            hello = await next_of(ws, "hello")
            assert [(r["name"], r["source"]) for r in hello["robots"]] == [
                ("up", "line1"),
                ("down", "line2"),
            ]
            first = await next_of(ws, "frame", "up")
            async with asyncio.timeout(15):
                while (h := await health(base))["sources"][1]["state"] != "error":
                    await asyncio.sleep(0.05)
            later = await next_of(ws, "frame", "up")
    assert first["ok"] and later["ok"] and later["seq"] > first["seq"]
    line1, line2 = h["sources"]
    assert (line1["name"], line1["state"], line1["mock"]) == ("line1", "connected", True)
    assert line2["state"] == "error" and "cannot reach" in line2["error"]
    robots = {r["name"]: r for r in h["robots"]}
    assert robots["up"]["ok"] is True and robots["down"]["ok"] is False
    assert h["status"] == "degraded"


async def test_reload_on_save_restarts_only_what_changed(tmp_path: Path) -> None:
    path = tmp_path / "cell.toml"
    path.write_text(cell_text(TWO_MOCKS, ("a", "line1", 0.0), ("b", "line2", 500.0)))
    async with running_server(Settings(cell=path)) as base:
        async with connect(base.replace("http", "ws") + "/ws") as ws:
            hello = await next_of(ws, "hello")
            assert [r["base"][0] for r in hello["robots"]] == [0.0, 0.5]
            await next_of(ws, "frame", "b")
            urls = {s["name"]: s["url"] for s in (await health(base))["sources"]}

            # Move robot b's base and add a robot c on line2: line2 restarts, line1 does not.
            robots = ("a", "line1", 0.0), ("b", "line2", 750.0), ("c", "line2", 1000.0)
            path.write_text(cell_text(TWO_MOCKS, *robots))
            hello = await next_of(ws, "hello")
            assert [(r["name"], r["base"][0]) for r in hello["robots"]] == [
                ("a", 0.0),
                ("b", 0.75),
                ("c", 1.0),
            ]
            assert (await next_of(ws, "frame", "c"))["ok"]
            after = {s["name"]: s["url"] for s in (await health(base))["sources"]}
            assert after["line1"] == urls["line1"], "line1 did not change: kept running"
            assert after["line2"] != urls["line2"], "line2 changed: a new mock, a new port"

            # A broken file: the running cell stays, every viewer is told why.
            path.write_text(path.read_text().replace('source = "line2"', 'source = "line3"', 1))
            notice = await next_of(ws, "cell")
            assert "robot[1] \"b\".source: no source named 'line3'" in notice["error"]
            assert (await next_of(ws, "frame", "c"))["ok"], "the old cell still streams"
            state = await health(base)
            assert "no source named 'line3'" in state["cell"]["error"]
            assert state["status"] == "degraded"
