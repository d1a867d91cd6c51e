"""HTTP routes: the page, its static files and meshes, and the health report."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import FileResponse, JSONResponse

from ..runtime import Runtime

ROOT = Path(__file__).resolve().parent.parent.parent
STATIC_DIR = ROOT / "static"
ASSETS_DIR = ROOT / "assets"

router = APIRouter()


def runtime_of(request: Request) -> Runtime:
    """The Runtime the app was started with."""
    runtime: Runtime = request.app.state.runtime
    return runtime


@router.get("/", include_in_schema=False)
async def index() -> FileResponse:
    """The viewer page."""
    return FileResponse(STATIC_DIR / "index.html")


@router.get("/api/health")
async def health(request: Request) -> JSONResponse:
    """Data-source state, sample age and per-robot errors; 200 while the service runs."""
    runtime = runtime_of(request)
    now = time.time()
    sources: list[dict[str, Any]] = []
    for source in runtime.sources:
        sources.append(
            {
                **source.status().model_dump(),
                "robots": {
                    name: {"ok": r.ok, "error": r.error, "frames": r.frames}
                    for name, r in source.robots.items()
                },
            }
        )
    healthy = all(s["state"] == "connected" for s in sources) and all(
        r["ok"] for s in sources for r in s["robots"].values()
    )
    return JSONResponse(
        {
            "status": "ok" if healthy else "degraded",
            "time": now,
            "sources": sources,
            "viewers": runtime.hub.viewer_count,
            "dropped_frames": runtime.hub.dropped,
        }
    )
