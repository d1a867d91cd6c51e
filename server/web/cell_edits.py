"""Changing the cell from the page: changes run unsaved, their diff, save, discard, undo; and
the robot descriptions found on this machine (``server.commissioning``).

``GET /api/cell`` says whether edits are allowed (and if not, how to allow
them). Everything else here answers 403 with that reason unless the server
runs with ``--allow-edits`` (or the cell says ``allow_edits = true``). Every
POST is JSON from this server's own page or a script, with the viewer token
where one is set: the same rules as moves (``guards``).
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Iterator
from typing import Annotated, Any, TypeVar

from fastapi import APIRouter, HTTPException, Query, Request
from pydantic import BaseModel, ConfigDict, Field

from ..cell.edit import CellText
from ..commissioning import Catalog, CellEditor, Changes, CommissioningError, maker, preview
from .routes import runtime_of
from .transformation import parse_body

router = APIRouter(prefix="/api")


class Save(BaseModel):
    """The unsaved version whose diff was shown (``unsaved.version`` of ``GET /api/cell``)."""

    model_config = ConfigDict(extra="forbid", strict=True)

    version: Annotated[str, Field(min_length=64, max_length=64)]


class Nothing(BaseModel):
    """An empty JSON object: the request says all by its path."""

    model_config = ConfigDict(extra="forbid")


def _editor(request: Request) -> CellEditor:
    editor: CellEditor = request.app.state.editor
    return editor


def _catalog(request: Request) -> Catalog:
    catalog: Catalog = request.app.state.catalog
    return catalog


def _allowed(editor: CellEditor) -> None:
    reason = editor.refusal()
    if reason is not None:
        raise HTTPException(403, reason)


Body = TypeVar("Body", bound=BaseModel)


async def _checked(request: Request, model: type[Body]) -> tuple[CellEditor, Body]:
    """The editor, if edits are allowed (403 with how to allow them), and the request's body."""
    editor = _editor(request)
    _allowed(editor)
    return editor, parse_body(model, await request.body())


@contextlib.contextmanager
def _answered() -> Iterator[None]:
    """A refused edit as the HTTP error its status says."""
    try:
        yield
    except CommissioningError as exc:
        raise HTTPException(exc.status, str(exc)) from None


@router.get("/cell")
async def cell(request: Request) -> dict[str, Any]:
    """The cell file: may the page change it (else ``why_not``), the unsaved changes, a backup."""
    return await _editor(request).status()


@router.post("/cell/changes")
async def changes(request: Request) -> dict[str, Any]:
    """Make ``Changes`` and run them at once, unsaved; 422 naming what does not fit (then
    none of them is made)."""
    editor, body = await _checked(request, Changes)
    runtime = runtime_of(request)
    with _answered():
        # Each decided against the cell as it runs now; all made together, or none.
        makers = [
            maker(change, runtime.cell, runtime.newest_values(), _catalog(request))
            for change in body.changes
        ]

        def make_all(text: CellText) -> None:
            for make in makers:
                make(text)

        return await editor.change(make_all)


@router.post("/cell/save")
async def save(request: Request) -> dict[str, Any]:
    """Write the unsaved changes whose diff was shown (``Save``); the old file stays as .bak."""
    editor, body = await _checked(request, Save)
    with _answered():
        return await editor.save(body.version)


@router.post("/cell/discard")
async def discard(request: Request) -> dict[str, Any]:
    """Drop the unsaved changes: the file as saved runs again."""
    editor, _ = await _checked(request, Nothing)
    with _answered():
        return await editor.discard()


@router.post("/cell/undo")
async def undo(request: Request) -> dict[str, Any]:
    """Put back the file as it was before the last save (the two swap: undo again redoes)."""
    editor, _ = await _checked(request, Nothing)
    with _answered():
        return await editor.undo()


@router.get("/descriptions")
async def descriptions(
    request: Request, robot: Annotated[str, Query(max_length=200)]
) -> dict[str, Any]:
    """Descriptions on this machine with as many joints as ``robot`` (cell folder first)."""
    editor = _editor(request)
    _allowed(editor)
    runtime = runtime_of(request)
    found = runtime.robot(robot)
    if found is None:
        raise HTTPException(404, f"no robot named {robot!r} in the cell")
    catalog = _catalog(request)
    listing = await asyncio.to_thread(catalog.listing, len(found.joints), runtime.cell.folder)
    return {
        "robot": robot,
        "joints": len(found.joints),
        "found": [
            {
                "id": d.id,
                "file": runtime.cell.shown(str(d.path)),
                "name": d.path.name,
                "origin": d.origin,
                "joints": list(d.joints),
            }
            for d in listing.matching
        ],
        "examined": listing.examined,
        "unreadable": listing.unreadable,
        "pending": listing.pending,
    }


@router.get("/descriptions/{id}")
async def description(id: str, request: Request) -> dict[str, Any]:
    """A listed description to preview: its links at zero joints and its joints."""
    _allowed(_editor(request))
    catalog = _catalog(request)
    with _answered():
        found = catalog.get(id)
        shown = await asyncio.to_thread(preview, found, catalog.packages(found))
    shown["file"] = runtime_of(request).cell.shown(str(found.path))
    shown["warnings"] = [runtime_of(request).cell.shown(w) for w in shown["warnings"]]
    return shown
