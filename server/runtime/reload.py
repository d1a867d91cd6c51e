"""Reload on save: when the cell file changes on disk, run the new version if it is valid.

The watcher outlives whatever a version of the file does: a file no check
foresaw (400 kB of nested brackets raised RecursionError, which ended the
watcher without a word, and later good saves were ignored), a cell that fails
to start, or the watch itself failing (the folder removed). Each is logged
and reported to viewers; the running cell goes on, and the next save is read.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from pathlib import Path

from watchfiles import Change, awatch

from ..cell import Cell, CellError
from ..cell.load import unreadable
from ..sandbox import stop_all
from . import Runtime

log = logging.getLogger(__name__)

RETRY_S = (1.0, 60.0)
"""First and longest pause before watching again after the watch itself failed."""


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
    pause = RETRY_S[0]

    def is_target(_change: Change, changed: str) -> bool:
        return Path(changed).resolve() == target

    while not stop.is_set():
        try:
            async for _ in awatch(
                target.parent, watch_filter=is_target, stop_event=stop, debounce=200, step=50
            ):
                await reload(runtime, path, load)
                pause = RETRY_S[0]
        except Exception:
            log.exception("watching %s for changes failed; watching again in %g s", path, pause)
            try:
                await asyncio.wait_for(stop.wait(), pause)
            except TimeoutError:
                pass
            pause = min(pause * 2, RETRY_S[1])


async def reload(runtime: Runtime, path: Path, load: Callable[[], Cell]) -> None:
    """Load the cell file again and run it; whatever fails is logged and shown, never raised."""
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
        log.error("cell file changed but cannot be used; still running the previous one:\n%s", exc)
        runtime.reject(str(exc))
        return
    except Exception as exc:  # a file no check foresaw: one line, the previous cell runs on
        error = unreadable(path, exc)
        log.error("cell file changed but cannot be used; still running the previous one:\n%s",
                  error, exc_info=exc)  # fmt: skip
        runtime.reject(str(error))
        return
    log.info("cell file %s changed: reloading", path)
    try:
        await runtime.apply(cell)
    except Exception as exc:  # the sources that were running still run (Runtime.apply)
        log.exception("reloading %s failed; still running the previous cell", path)
        runtime.reject(f"{path}: reloading failed: {type(exc).__name__}: {exc}")
