"""Reload on save: only the cell file wakes the reload, whatever else its folder holds."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from pathlib import Path
from typing import Any, cast

import pytest

from server.runtime import Runtime
from server.runtime.reload import follow_cell_file


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
