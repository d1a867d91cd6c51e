"""``--record DIR``: every live source recorded to MCAP files, one per hour or per 500 MB.

Once a second the histories' new rows are copied out on the event loop (a
few array copies) and handed to a worker thread, which recomputes the poses
in one batch, encodes and writes them. A reloaded cell starts a new file, so
each file holds one cell, attached.
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime as dt
import logging
import time
from collections.abc import Callable
from pathlib import Path

from ..cell import Cell
from ..history import History, HistoryReader, Mark, NewRows
from .encode import encode_batch
from .writer import McapFile

log = logging.getLogger(__name__)

DRAIN_S = 1.0
MAX_FILE_S = 3600.0
MAX_FILE_BYTES = 500 * 1024 * 1024


def file_name(t: float) -> str:
    """``linkview-20250101-120000.mcap`` (UTC)."""
    return dt.datetime.fromtimestamp(t, dt.UTC).strftime("linkview-%Y%m%d-%H%M%S.mcap")


class Recorder:
    """Records the histories of a running cell into ``folder`` until cancelled."""

    def __init__(
        self,
        history: History,
        cell_of: Callable[[], Cell],
        folder: Path,
        max_file_s: float = MAX_FILE_S,
        max_file_bytes: int = MAX_FILE_BYTES,
    ) -> None:
        self.folder = folder
        self.cell_of = cell_of
        self.max_file_s = max_file_s
        self.max_file_bytes = max_file_bytes
        self.reader = HistoryReader(history, from_start=True)
        self.file: McapFile | None = None
        self.files: list[Path] = []
        """Every file this recorder opened, oldest first."""
        self.error: str | None = None

    async def run(self, drain_s: float = DRAIN_S) -> None:
        """Drain once every ``drain_s``; on cancellation, write what is left and close."""
        try:
            while True:
                await asyncio.sleep(drain_s)
                await self.drain()
        finally:
            await asyncio.shield(self._finish())

    async def drain(self) -> None:
        """Record what the histories gained since the last drain."""
        cell = self.cell_of()
        sources, marks = self.reader.take(cell)
        try:
            await asyncio.to_thread(self._write, cell, sources, marks)
            self.error = None
        except Exception as exc:  # a full disk (or a bug) must not stop the viewers
            if self.error is None:
                log.error("recording to %s failed: %s", self.folder, exc)
            self.error = str(exc)
            broken, self.file = self.file, None  # a new file once writing works again
            if broken is not None:
                with contextlib.suppress(Exception):
                    await asyncio.to_thread(broken.close)

    async def _finish(self) -> None:
        try:
            await self.drain()
        finally:
            if self.file is not None:
                await asyncio.to_thread(self.file.close)
                log.info("recording closed: %s", self.file.path)
                self.file = None

    def _write(self, cell: Cell, sources: list[NewRows], marks: list[Mark]) -> None:
        """Worker thread: rotate if due, encode, write."""
        file = self.file
        due = file is not None and (
            file.cell is not cell
            or time.monotonic() - file.opened >= self.max_file_s
            or file.size >= self.max_file_bytes
        )
        if file is not None and due:
            file.close()
            log.info("recording closed: %s", file.path)
            file = None
        if file is None:
            path = self._new_path()
            # The file's scene and base frames must not be younger than its first sample.
            first = [float(s.rows.t[0]) for s in sources if len(s.rows)]
            file = McapFile(path, cell, min(first, default=time.time()))
            self.files.append(path)
            log.info("recording to %s", path)
        self.file = file
        file.write(encode_batch(sources, marks, file.frames))

    def _new_path(self) -> Path:
        path = self.folder / file_name(time.time())
        n = 1
        while path.exists() or path in self.files:
            path = self.folder / f"{path.stem.split('.')[0]}.{n}.mcap"
            n += 1
        return path
