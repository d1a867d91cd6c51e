"""Reload on save: when the cell file changes on disk, run the new version if it is valid."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from pathlib import Path

from watchfiles import Change, awatch

from ..cell import Cell, CellError
from ..sandbox import stop_all
from . import Runtime

log = logging.getLogger(__name__)


async def follow_cell_file(
    runtime: Runtime, path: Path, load: Callable[[], Cell], stop: asyncio.Event
) -> None:
    """Watch ``path`` until ``stop`` is set; apply each valid version, report each invalid one.

    The folder is watched rather than the file: editors often save by
    writing a new file and renaming it over the old one. Changes to other
    files there (a log written beside the cell, say) are filtered out before
    watchfiles logs them, so they neither wake the reload nor flood the log.
    """
    target = path.resolve()

    def is_target(_change: Change, changed: str) -> bool:
        return Path(changed).resolve() == target

    async for _ in awatch(
        target.parent, watch_filter=is_target, stop_event=stop, debounce=200, step=50
    ):
        try:
            # Parsing a URDF or converting meshes may take a while: not on the event loop.
            # A xacro file is expanded by a worker process the thread waits for.
            cell = await asyncio.to_thread(load)
        except asyncio.CancelledError:
            # Stopping: the thread would wait for a running worker (up to its limits),
            # and the loop's executor waits for the thread before the process exits.
            stop_all()
            raise
        except CellError as exc:
            log.error(
                "cell file changed but cannot be used; still running the previous one:\n%s", exc
            )
            runtime.reject(str(exc))
            continue
        log.info("cell file %s changed: reloading", path)
        try:
            await runtime.apply(cell)
        except Exception as exc:  # the watcher must outlive any one bad version of the file
            log.exception("reloading %s failed", path)
            runtime.reject(f"{path}: reloading failed: {exc}")
