"""Changing the cell file through the API: allowed only with --allow-edits, run at once,
saved after the diff with a backup, reloaded as on any save, undone.

A still robot (an embedded mock with one demo target) shows each change in
``/api/robots`` exactly: the Type 12's raw values are 10000 and 20000 (node
units), so a mapping's effect is known without the server's arithmetic.
"""

from __future__ import annotations

import asyncio
import math
from pathlib import Path
from typing import Any

import aiohttp
import pytest

from server.config import Settings
from server.paths import DEMO_CELL
from tests.commissioning.cells import SOURCE, STILL
from tests.commissioning.cells import cell_file as written
from tests.conftest import running_server

CELL = "# The commissioning test cell: this comment must survive every save.\n" + SOURCE + STILL
ENABLE = "--allow-edits"


async def request(
    http: aiohttp.ClientSession, method: str, url: str, body: Any = None
) -> tuple[int, Any]:
    async with http.request(method, url, json=body) as response:
        kind = response.headers.get("content-type", "")
        answer = await (response.json() if "json" in kind else response.text())
        return response.status, answer


async def robot(http: aiohttp.ClientSession, base: str, name: str = "still") -> dict[str, Any]:
    """The robot as ``/api/robots`` shows it, once it has a value."""
    async with asyncio.timeout(20):
        while True:
            _, robots = await request(http, "GET", f"{base}/api/robots")
            (found,) = [r for r in robots if r["name"] == name]
            if all(j["value"] is not None for j in found["joints"]):
                return found
            await asyncio.sleep(0.05)


async def until(check: Any, timeout_s: float = 20.0) -> None:
    """Await ``check()`` until it is true (the file watcher reloads within a second)."""
    async with asyncio.timeout(timeout_s):
        while not await check():
            await asyncio.sleep(0.05)


@pytest.fixture
def cell_file(tmp_path: Path) -> Path:
    return written(tmp_path, CELL)


async def test_without_allow_edits_every_write_is_refused_with_how_to_allow_it(
    cell_file: Path,
) -> None:
    async with running_server(Settings(cell=cell_file)) as base, aiohttp.ClientSession() as http:
        status, cell = await request(http, "GET", f"{base}/api/cell")
        assert status == 200 and cell["editable"] is False and ENABLE in cell["why_not"]
        change = {"op": "joint", "robot": "still", "joint": "a0", "scale": -0.001}
        for path, body in (
            ("/api/cell/changes", {"changes": [change]}),
            ("/api/cell/save", {"version": "0" * 64}),
            ("/api/cell/discard", {}),
            ("/api/cell/undo", {}),
        ):
            status, answer = await request(http, "POST", base + path, body)
            assert status == 403 and ENABLE in answer["detail"], (path, answer)
        status, answer = await request(http, "GET", f"{base}/api/descriptions?robot=still")
        assert status == 403 and ENABLE in answer["detail"]
        assert [j["scale"] for j in (await robot(http, base))["joints"]] == [0.001, 0.001]
    assert cell_file.read_text() == CELL and not (cell_file.parent / "cell.toml.bak").exists()


async def test_allow_edits_in_the_cell_file_allows_them(cell_file: Path) -> None:
    cell_file.write_text("allow_edits = true\n" + CELL)
    async with running_server(Settings(cell=cell_file)) as base, aiohttp.ClientSession() as http:
        assert (await request(http, "GET", f"{base}/api/cell"))[1]["editable"] is True


async def test_the_shipped_demo_cell_is_never_written() -> None:
    before = DEMO_CELL.read_text()
    async with running_server(Settings(allow_edits=True)) as base, aiohttp.ClientSession() as http:
        _, cell = await request(http, "GET", f"{base}/api/cell")
        assert cell["editable"] is False and "demo cell" in cell["why_not"]
        change = {"op": "base", "robot": "kin12", "xyz": [0, 0, 0], "rpy": [0, 0, 0]}
        status, _ = await request(http, "POST", f"{base}/api/cell/changes", {"changes": [change]})
        assert status == 403
    assert DEMO_CELL.read_text() == before


async def test_a_change_runs_at_once_is_saved_after_its_diff_and_undone(cell_file: Path) -> None:
    settings = Settings(cell=cell_file, allow_edits=True)
    async with running_server(settings) as base, aiohttp.ClientSession() as http:
        assert [j["value_si"] for j in (await robot(http, base))["joints"]] == pytest.approx(
            [math.radians(10.0), math.radians(20.0)]
        )
        flip = {"op": "joint", "robot": "still", "joint": "a0", "scale": -0.001}
        status, cell = await request(http, "POST", f"{base}/api/cell/changes", {"changes": [flip]})
        assert status == 200, cell
        # Running, not written: the model turns the other way now, the file is as it was.
        await until(
            lambda: _value_si(http, base, 0, -math.radians(10.0)),
        )
        assert cell_file.read_text() == CELL
        diff = cell["unsaved"]["diff"]
        minus = [line for line in diff.splitlines() if line.startswith("-") and "---" not in line]
        plus = [line for line in diff.splitlines() if line.startswith("+") and "+++" not in line]
        line = '    { node = "plc/app/Application/sym/PLC_PRG/a0", unit = "deg", scale = %s },'
        assert minus == ["-" + line % "0.001"] and plus == ["+" + line % "-0.001"]
        # Saving needs the version whose diff was shown.
        status, answer = await request(http, "POST", f"{base}/api/cell/save", {"version": "f" * 64})
        assert status == 409 and "diff" in answer["detail"]
        version = cell["unsaved"]["version"]
        status, saved = await request(http, "POST", f"{base}/api/cell/save", {"version": version})
        assert status == 200 and saved["unsaved"] is None and saved["backup"] == "cell.toml.bak"
        expected = CELL.replace(line % "0.001", line % "-0.001")
        assert cell_file.read_text() == expected  # the comments and the key order stay
        assert (cell_file.parent / "cell.toml.bak").read_text() == CELL
        # Undo puts the file before the save back; the server reloads it as on a save.
        status, undone = await request(http, "POST", f"{base}/api/cell/undo", {})
        assert status == 200 and cell_file.read_text() == CELL
        assert (cell_file.parent / "cell.toml.bak").read_text() == expected
        await until(lambda: _value_si(http, base, 0, math.radians(10.0)))
        status, _ = await request(http, "POST", f"{base}/api/cell/undo", {})  # and again: redo
        assert status == 200 and cell_file.read_text() == expected
        await until(lambda: _value_si(http, base, 0, -math.radians(10.0)))


async def _value_si(http: aiohttp.ClientSession, base: str, joint: int, want: float) -> bool:
    return abs((await robot(http, base))["joints"][joint]["value_si"] - want) < 1e-12


async def test_this_joint_reads_x_now_sets_the_offset_that_makes_it_so(cell_file: Path) -> None:
    settings = Settings(cell=cell_file, allow_edits=True)
    async with running_server(settings) as base, aiohttp.ClientSession() as http:
        await robot(http, base)
        reads = {"op": "joint_reads", "robot": "still", "joint": "a1", "value": math.radians(-5.0)}
        status, cell = await request(http, "POST", f"{base}/api/cell/changes", {"changes": [reads]})
        assert status == 200, cell
        # raw 20000 x 0.001 + offset = -5 degrees: offset = -25 (in the node's unit, degrees).
        assert 'unit = "deg", scale = 0.001, offset = -25.0 }' in cell["unsaved"]["diff"]
        await until(lambda: _value_si(http, base, 1, math.radians(-5.0)))


async def test_a_change_the_cell_cannot_take_is_refused_and_nothing_changes(
    cell_file: Path,
) -> None:
    settings = Settings(cell=cell_file, allow_edits=True)
    async with running_server(settings) as base, aiohttp.ClientSession() as http:
        await robot(http, base)
        for change, reason in (
            ({"joint": "a0", "scale": 0.0}, "joints[0].scale: must not be 0"),
            ({"joint": "a0", "unit": "mm"}, "unit must be deg or rad"),
            ({"robot": "nobody", "joint": "a0", "scale": 1.0}, "no robot named 'nobody'"),
            ({"joint": "a9", "scale": 1.0}, "still has no joint 'a9'"),
        ):
            change = {"op": "joint", "robot": "still", **change}
            status, answer = await request(
                http, "POST", f"{base}/api/cell/changes", {"changes": [change]}
            )
            assert status in (404, 422) and reason in answer["detail"], answer
        _, cell = await request(http, "GET", f"{base}/api/cell")
        assert cell["unsaved"] is None
        # Not JSON of the right shape: the schema's 422, as for every request.
        wrong = {"changes": [{"op": "x"}]}
        status, _ = await request(http, "POST", f"{base}/api/cell/changes", wrong)
        assert status == 422
    assert cell_file.read_text() == CELL


async def test_a_file_changed_on_disk_meanwhile_is_not_overwritten(cell_file: Path) -> None:
    settings = Settings(cell=cell_file, allow_edits=True)
    async with running_server(settings) as base, aiohttp.ClientSession() as http:
        await robot(http, base)
        place = {"op": "base", "robot": "still", "xyz": [0.5, 0.25, 0], "rpy": [0, 0, math.pi / 2]}
        _, cell = await request(http, "POST", f"{base}/api/cell/changes", {"changes": [place]})
        assert (
            "base = { xyz = [500.0, 250.0, 0.0], rpy_deg = [0.0, 0.0, 90.0] }"
            in (cell["unsaved"]["diff"])
        )
        edited_by_hand = CELL.replace("# held at one pose", "# edited by hand")
        cell_file.write_text(edited_by_hand)
        status, answer = await request(
            http, "POST", f"{base}/api/cell/save", {"version": cell["unsaved"]["version"]}
        )
        assert status == 409 and "changed on disk" in answer["detail"]
        status, cell = await request(http, "POST", f"{base}/api/cell/discard", {})
        assert status == 200 and cell["unsaved"] is None
    assert cell_file.read_text() == edited_by_hand
