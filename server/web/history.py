"""``GET /api/history``: the timeline's range and marks, windows of samples;
``POST /api/history/recording``: the last minutes saved as an MCAP file.

Windows are computed in a worker thread from the source's history (poses by
the batch kinematics); the live stream and other viewers are not involved.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import shutil
import tempfile
import time
from pathlib import Path
from typing import Annotated, Any, Literal

from fastapi import APIRouter, HTTPException, Query, Request
from fastapi.responses import JSONResponse, Response
from pydantic import BaseModel, ConfigDict, Field

from ..history import encode_binary, encode_json, source_window
from ..recording import history_rows, write_export
from ..recording.continuous import file_name
from .download import FileDownload
from .routes import runtime_of
from .slots import Slots

router = APIRouter()

MAX_POSES_S = 120.0
"""Poses are recomputed per request: at most this long a window with poses."""
BINARY = "application/vnd.linkview.history"
EXPORT_RETRY_S = 5


@router.get("/api/history", response_model=None)
async def history(
    request: Request,
    source: str | None = None,
    t_from: Annotated[float | None, Query(alias="from", allow_inf_nan=False)] = None,
    t_to: Annotated[float | None, Query(alias="to", allow_inf_nan=False)] = None,
    poses: Literal["links", "tcp", "none"] = "links",
    format: Literal["binary", "json"] = "binary",
) -> Response:
    """Without ``source``: every source's span and the marks. With it: a window of samples."""
    runtime = runtime_of(request)
    if source is None:
        return JSONResponse(_summary(request))
    kept = runtime.history.sources.get(source)
    if kept is None:
        raise HTTPException(status_code=404, detail=f"no source named {source!r}")
    low = -math.inf if t_from is None else t_from
    high = math.inf if t_to is None else t_to
    if low > high:
        raise HTTPException(status_code=422, detail="'from' is after 'to'")
    rows = kept.ring.between(low, high)
    if poses != "none" and len(rows) > 1 and rows.t[-1] - rows.t[0] > MAX_POSES_S:
        raise HTTPException(
            status_code=422,
            detail=f"at most {MAX_POSES_S:g} s of poses per request; ask for poses=none",
        )
    robots = [(i, r) for i, r in enumerate(runtime.robots) if r.source == source]
    windows = await asyncio.to_thread(source_window, robots, rows, kept.ring.column, poses)
    first = float(rows.t[0]) if len(rows) else 0.0
    last = float(rows.t[-1]) if len(rows) else 0.0
    low, high = (low if math.isfinite(low) else first), (high if math.isfinite(high) else last)
    encode = encode_json if format == "json" else encode_binary
    body = encode(source, low, high, rows, windows, poses)
    return Response(body, media_type="application/json" if format == "json" else BINARY)


def _summary(request: Request) -> dict[str, Any]:
    runtime = runtime_of(request)
    history = runtime.history
    sources = []
    for name, kept in history.sources.items():
        span = kept.ring.span()
        sources.append(
            {
                "name": name,
                "from": None if span is None else span[0],
                "to": None if span is None else span[1],
                "samples": len(kept.ring),
                "bytes": kept.ring.nbytes,
                "replay": kept.frozen,
            }
        )
    oldest = history.span()
    marks = history.marks.since(oldest[0] if oldest else 0.0)
    return {
        "seconds": history.seconds,
        "time": time.time(),
        "sources": sources,
        "marks": [{"t": m.t, "kind": m.kind, "source": m.source, "text": m.text} for m in marks],
    }


class RecordingRequest(BaseModel):
    """How much of the history to save."""

    model_config = ConfigDict(extra="forbid")

    minutes: float = Field(5.0, gt=0.0, le=1440.0)


@router.post("/api/history/recording", response_model=None)
async def recording(request: Request, body: RecordingRequest) -> Response:
    """The last ``minutes`` of history as an MCAP file (Foxglove opens it), for download.

    A POST with a JSON body, so only this server's own page (or a script)
    can ask for one (``guards``). One at a time, others 503 with
    ``Retry-After``; written off the event loop a window at a time and sent
    from its temporary file in chunks, so memory does not grow with the span.
    """
    runtime = runtime_of(request)
    seconds = min(body.minutes * 60.0, runtime.history.seconds)
    cell = runtime.cell
    held = contextlib.AsyncExitStack()
    await held.enter_async_context(exports.slot())
    folder = Path(tempfile.mkdtemp(prefix="linkview-"))
    held.callback(shutil.rmtree, folder, ignore_errors=True)
    try:
        sources, marks, t0 = history_rows(runtime.history, cell, seconds)
        path = folder / "export.mcap"
        await asyncio.to_thread(write_export, path, cell, sources, marks, t0)
    except BaseException:
        await held.aclose()
        raise
    return FileDownload(path, file_name(time.time()), held.aclose)


exports = Slots("a recording is being saved (one at a time)", 1, retry_s=EXPORT_RETRY_S)
"""This process's saved recordings."""
