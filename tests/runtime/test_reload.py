"""Reload on save: only the cell file wakes the reload, whatever else its folder holds; no
file, however broken, and no failing reload ends the watcher."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from pathlib import Path
from typing import Any, cast

import pytest

from server.cell import load_cell
from server.runtime import Runtime
from server.runtime.reload import follow_cell_file
from tests.e2e.test_cells import cell_text


class Recorder:
    """Stands in for the Runtime: remembers what the watcher asked of it."""

    def __init__(self) -> None:
        self.applied: list[object] = []

    async def apply(self, cell: object) -> None:
        self.applied.append(cell)

    def reject(self, error: str) -> None:
        raise AssertionError(f"unexpected rejection: {error}")


async def test_other_files_in_the_folder_neither_reload_nor_log(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    cell = tmp_path / "cell.toml"
    cell.write_text("# v1\n")
    loads: list[str] = []
    runtime = Recorder()
    stop = asyncio.Event()

    def load() -> Any:
        loads.append(cell.read_text())
        return object()

    caplog.set_level(logging.INFO)
    watcher = asyncio.create_task(follow_cell_file(cast(Runtime, runtime), cell, load, stop))
    try:
        await asyncio.sleep(0.5)  # the watch is set up
        log_file = tmp_path / "server.log"
        for i in range(20):  # a log written beside the cell, as a server or worker does
            with log_file.open("a") as out:
                out.write(f"line {i}\n")
            await asyncio.sleep(0.02)
        await asyncio.sleep(0.6)
        assert loads == [], "a change to another file reloaded the cell"
        assert not [r for r in caplog.records if r.name.startswith("watchfiles")]

        cell.write_text("# v2\n")
        async with asyncio.timeout(10):
            while not runtime.applied:
                await asyncio.sleep(0.05)
        assert loads == ["# v2\n"]
    finally:
        stop.set()
        watcher.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await watcher


class Rejections(Recorder):
    """A Runtime stand-in that also remembers what it was told could not be used."""

    def __init__(self, fail_apply: int = 0) -> None:
        super().__init__()
        self.rejected: list[str] = []
        self.fail_apply = fail_apply

    async def apply(self, cell: object) -> None:
        if self.fail_apply:
            self.fail_apply -= 1
            raise MemoryError("a chunk claims 4 EiB")
        await super().apply(cell)

    def reject(self, error: str) -> None:
        self.rejected.append(error)


async def saves(cell: Path, runtime: Rejections, load: Any, *versions: str) -> None:
    """Write each version of the file, waiting until the watcher answered it."""
    stop = asyncio.Event()
    watcher = asyncio.create_task(follow_cell_file(cast(Runtime, runtime), cell, load, stop))
    try:
        await asyncio.sleep(0.5)  # the watch is set up
        for text in versions:
            answered = len(runtime.applied) + len(runtime.rejected)
            cell.write_text(text)
            async with asyncio.timeout(15):
                while len(runtime.applied) + len(runtime.rejected) == answered:
                    assert not watcher.done(), f"the watcher ended: {watcher}"
                    await asyncio.sleep(0.05)
    finally:
        stop.set()
        with contextlib.suppress(asyncio.CancelledError):
            await asyncio.wait_for(watcher, 5)


GOOD = cell_text('[[source]]\nname = "line1"\n', ("arm", "line1", 0.0))
DEEP = "x = " + "[" * 200_000 + "]" * 200_000 + "\n"
"""400 kB of nested brackets: tomllib recursed until RecursionError."""


async def test_deeply_nested_toml_is_one_line_and_later_saves_still_reload(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    cell = tmp_path / "cell.toml"
    good = GOOD
    cell.write_text(good)
    runtime = Rejections()
    caplog.set_level(logging.INFO)
    await saves(cell, runtime, lambda: load_cell(cell), DEEP, good)
    assert len(runtime.rejected) == 1 and len(runtime.applied) == 1
    (error,) = runtime.rejected
    assert error == f"{cell}: (file): nests tables or arrays too deeply to read"
    logged = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert len(logged) == 1 and logged[0].exc_info is None
    assert logged[0].getMessage().splitlines()[1:] == [error]


async def test_the_watcher_outlives_any_exception_of_a_load_or_a_reload(tmp_path: Path) -> None:
    cell = tmp_path / "cell.toml"
    cell.write_text("# v1\n")
    failures = [RecursionError("maximum recursion depth exceeded"), OverflowError("2**70")]

    def load() -> Any:
        if failures:
            raise failures.pop(0)
        return cell.read_text()

    runtime = Rejections(fail_apply=1)
    await saves(cell, runtime, load, "# v2\n", "# v3\n", "# v4\n", "# v5\n")
    assert [r.split(": ", 2)[2] for r in runtime.rejected[:2]] == [
        "cannot be read: RecursionError: maximum recursion depth exceeded",
        "cannot be read: OverflowError: 2**70",
    ]
    assert "reloading failed: MemoryError: a chunk claims 4 EiB" in runtime.rejected[2]
    assert runtime.applied == ["# v5\n"]
