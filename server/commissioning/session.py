"""Changing the cell file from the page: unsaved changes run at once, then are saved, or undone.

Every change is made to the file's text (``server.cell.edit``, which keeps
comments, key order and layout), loaded as the server loads the file, and run
at once, so the page shows its effect; nothing is written yet. ``save`` writes
the changed text after its diff was shown (the caller names the version it
showed), keeping the file as it was in ``<file>.bak``; the server then reloads
the file as it does on any save. ``undo`` swaps the file and its backup back.
Writes replace the file in one step (a temporary file renamed over it), so a
reader never sees half a file.

Nothing is changed unless ``--allow-edits`` (or ``allow_edits = true`` in the
cell) says so; the shipped demo cell and replayed recordings are never written.
"""

from __future__ import annotations

import asyncio
import difflib
import hashlib
import logging
import os
import secrets
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..cell import Cell, CellError
from ..cell.edit import CellText, EditError
from ..paths import DEMO_CELL
from ..runtime import Runtime
from .errors import CommissioningError

log = logging.getLogger(__name__)

ENABLE = "start linkview with --allow-edits (or put allow_edits = true at the top of the cell file)"
"""How to turn editing on, as every refusal and every disabled control says it."""
BACKUP_SUFFIX = ".bak"

Loader = Callable[[Path, str | None], Cell]
"""Loads the cell file (or, given text, the file as it would be) as the server runs it."""


@dataclass(frozen=True)
class Draft:
    """Changes made but not saved: the file's new text and the version it was made from."""

    text: str
    based_on: str
    """sha256 of the file on disk when the first of these changes was made."""
    changes: int


def digest(text: str) -> str:
    """The sha256 (hex) that names a version of the file's text."""
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def backup_of(path: Path) -> Path:
    """Where the file as it was before the last save is kept."""
    return path.with_name(path.name + BACKUP_SUFFIX)


def _read(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise CommissioningError(409, f"cannot read the cell file: {exc}") from None


def _write(path: Path, text: str) -> None:
    """Replace ``path`` with ``text`` in one step, keeping its permissions."""
    temporary = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")
    try:
        temporary.write_text(text, encoding="utf-8")
        if path.exists():
            shutil.copymode(path, temporary)
        os.replace(temporary, path)
    except OSError as exc:
        temporary.unlink(missing_ok=True)
        raise CommissioningError(409, f"cannot write {path.name}: {exc}") from None


class CellEditor:
    """The unsaved changes of the running cell's file, and saving and undoing them."""

    def __init__(
        self,
        runtime: Runtime,
        load: Loader,
        allow_edits: bool,
        why_never: str | None = None,
    ) -> None:
        self.runtime = runtime
        self._load = load
        self.allow_edits = allow_edits
        self.why_never = why_never
        """Why this server never edits (a replay, a cluster replica), whatever the flags."""
        self.draft: Draft | None = None
        self._lock = asyncio.Lock()

    @property
    def path(self) -> Path | None:
        """The cell file the server runs (None: a cell made in code)."""
        return self.runtime.cell.path

    def refusal(self) -> str | None:
        """Why changes are refused now, with how to allow them; None where they are allowed."""
        spec = self.runtime.cell.spec
        if not (self.allow_edits or (spec is not None and spec.allow_edits)):
            return f"editing the cell is off: {ENABLE}"
        if self.why_never is not None:
            return self.why_never
        path = self.path
        if path is None:
            return "this cell has no file to save to: serve a cell file with --cell FILE"
        if path.resolve() == DEMO_CELL.resolve():
            return "the shipped demo cell is not edited: serve a copy of it with --cell FILE"
        return None

    def _path(self) -> Path:
        reason = self.refusal()
        if reason is not None:
            raise CommissioningError(403, reason)
        assert self.path is not None
        return self.path

    async def status(self) -> dict[str, Any]:
        """Whether changes are allowed (and if not, why), the unsaved ones and their diff."""
        path = self.path
        reason = self.refusal()
        body: dict[str, Any] = {
            "path": None if path is None else path.name,
            "editable": reason is None,
            "why_not": reason,
            "unsaved": None,
            "backup": None,
        }
        if path is None:
            return body
        if self.draft is not None:
            on_disk = await asyncio.to_thread(_read, path)
            body["unsaved"] = {
                "version": digest(self.draft.text),
                "changes": self.draft.changes,
                "diff": unified_diff(path.name, on_disk, self.draft.text),
                "stale": digest(on_disk) != self.draft.based_on,
            }
        backup = backup_of(path)
        body["backup"] = backup.name if backup.is_file() else None
        return body

    async def change(self, make: Callable[[CellText], None]) -> dict[str, Any]:
        """Make a change to the file's text (``make``) and run the result; not saved yet.

        Refused (422, nothing changes) where the result is not a cell the server
        can run, with every problem the loader names.
        """
        path = self._path()
        async with self._lock:
            on_disk = await asyncio.to_thread(_read, path)
            if self.draft is not None and digest(on_disk) != self.draft.based_on:
                raise CommissioningError(
                    409,
                    f"{path.name} changed on disk since the unsaved changes were made: "
                    "discard them first",
                )
            before = on_disk if self.draft is None else self.draft.text
            try:
                text = CellText(before)
                make(text)
            except EditError as exc:
                raise CommissioningError(422, str(exc)) from None
            after = text.text
            if after != before:
                try:
                    cell = await asyncio.to_thread(self._load, path, after)
                except CellError as exc:
                    raise CommissioningError(422, self.runtime.cell.shown(str(exc))) from None
                await self._run(cell, "the change")
                changes = 1 if self.draft is None else self.draft.changes + 1
                self.draft = None if after == on_disk else Draft(after, digest(on_disk), changes)
                log.info("cell %s: changed from the page (not saved)", path.name)
        return await self.status()

    async def save(self, version: str) -> dict[str, Any]:
        """Write the unsaved changes, if ``version`` names them (the diff that was shown)."""
        path = self._path()
        async with self._lock:
            if self.draft is None:
                raise CommissioningError(409, "nothing to save: there are no unsaved changes")
            if version != digest(self.draft.text):
                raise CommissioningError(
                    409, "the changes are not the ones whose diff was shown: look at it again"
                )
            on_disk = await asyncio.to_thread(_read, path)
            if digest(on_disk) != self.draft.based_on:
                raise CommissioningError(
                    409, f"{path.name} changed on disk since these changes were made: discard them"
                )
            await asyncio.to_thread(_write, backup_of(path), on_disk)
            await asyncio.to_thread(_write, path, self.draft.text)
            self.draft = None
            log.info("cell %s saved from the page (the previous one: %s)", path, backup_of(path))
        return await self.status()

    async def discard(self) -> dict[str, Any]:
        """Drop the unsaved changes: run the file as it is on disk again."""
        path = self._path()
        async with self._lock:
            if self.draft is not None:
                try:
                    cell = await asyncio.to_thread(self._load, path, None)
                except CellError as exc:
                    self.runtime.reject(str(exc))
                else:
                    # Kept unless the file's cell runs: the changes are what still runs.
                    await self._run(cell, "the cell file as saved")
                self.draft = None
        return await self.status()

    async def _run(self, cell: Cell, what: str) -> None:
        """Run ``cell``; where it cannot start, the running cell goes on (``Runtime.apply``)
        and the page is told why (422), not left with a server error."""
        try:
            await self.runtime.apply(cell)
        except Exception as exc:
            log.exception("cell %s: %s cannot run", cell.path, what)
            reason = f"{what} cannot run ({type(exc).__name__}: {exc}); the running cell goes on"
            raise CommissioningError(422, self.runtime.cell.shown(reason)) from None

    async def undo(self) -> dict[str, Any]:
        """Put the file before the last save back (and keep the newer one as the backup)."""
        path = self._path()
        async with self._lock:
            if self.draft is not None:
                raise CommissioningError(409, "save or discard the unsaved changes first")
            backup = backup_of(path)
            if not backup.is_file():
                raise CommissioningError(409, f"nothing to undo: there is no {backup.name}")
            previous = await asyncio.to_thread(_read, backup)
            current = await asyncio.to_thread(_read, path)
            await asyncio.to_thread(_write, backup, current)
            await asyncio.to_thread(_write, path, previous)
            log.info("cell %s: the save before was put back (undo)", path)
        return await self.status()


def unified_diff(name: str, before: str, after: str) -> str:
    """What a change does to the file, as ``diff -u`` shows it."""
    lines = difflib.unified_diff(
        before.splitlines(keepends=True),
        after.splitlines(keepends=True),
        fromfile=f"{name} (saved)",
        tofile=f"{name} (changed)",
    )
    return "".join(line if line.endswith("\n") else line + "\n" for line in lines)
