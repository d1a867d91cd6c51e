"""HTTP routes: the page, link meshes, the robot list and the health report."""

from __future__ import annotations

import time
from typing import Any, Literal

from fastapi import APIRouter, HTTPException, Request
from fastapi.responses import FileResponse, JSONResponse, Response

from ..cell.mesh_files import glb_problem
from ..coarse import CoarseError, CoarseMeshes
from ..paths import STATIC_DIR
from ..runtime import Runtime
from ..stream import load_summary

router = APIRouter()


def runtime_of(request: Request) -> Runtime:
    """The Runtime the app was started with."""
    runtime: Runtime = request.app.state.runtime
    return runtime


@router.get("/", include_in_schema=False)
async def index() -> FileResponse:
    """The viewer page."""
    return FileResponse(STATIC_DIR / "index.html")


@router.get("/meshes/{robot}/{link}.glb", include_in_schema=False)
async def mesh(
    robot: str, link: int, request: Request, detail: Literal["full", "coarse"] = "full"
) -> Response:
    """A robot's link GLB (hello gives its URL); ``?detail=coarse``: the 2D view's."""
    found = runtime_of(request).robot(robot)
    path = found.meshes[link] if found is not None and 0 <= link < len(found.meshes) else None
    # Checked when the cell was read, and again now: the file may have changed since.
    if path is None or glb_problem(path) is not None:
        raise HTTPException(status_code=404, detail=f"no mesh for link {link} of {robot!r}")
    if detail == "full":
        return FileResponse(path, media_type="model/gltf-binary")
    coarse: CoarseMeshes = request.app.state.coarse_meshes
    try:
        data = await coarse.get(path)
    except CoarseError as exc:
        raise HTTPException(
            status_code=404, detail=f"no coarse mesh for link {link} of {robot!r}: {exc}"
        ) from None
    return Response(data, media_type="model/gltf-binary")


@router.get("/api/robots")
async def robots(request: Request) -> list[dict[str, Any]]:
    """Every robot: joints with their nodes, mapping, limits and newest raw value; links, source."""
    runtime = runtime_of(request)
    healths = {source.name: source for source in runtime.healths()}  # a replica's too
    out = []
    shown_infos = runtime.cell.infos(runtime.commandable, runtime.hold_s)
    for robot, shown in zip(runtime.robots, shown_infos, strict=True):
        info = shown.model_dump()
        source = healths.get(robot.source)
        state = None if source is None else source.robots.get(robot.name)
        raw = None if state is None else state.values
        for k, (joint, entry) in enumerate(zip(robot.joints, info["joints"], strict=True)):
            # As read from the node (its unit), and what the mapping makes of it.
            value = None if raw is None else float(raw[k])
            entry.update(
                value=value,
                value_si=None if value is None else joint.to_si(value),
            )
        out.append(info)
    return out


@router.get("/api/health")
async def health(request: Request) -> JSONResponse:
    """Every source's state and sample age, every robot's error; 503 when no source is live."""
    runtime = runtime_of(request)
    sources: list[dict[str, Any]] = []
    robots: list[dict[str, Any]] = []
    by_name = {source.name: source for source in runtime.healths()}
    for source in by_name.values():
        sources.append(
            {
                **source.status().model_dump(),
                "robots": {
                    name: {"ok": r.ok, "error": r.error, "frames": r.frames}
                    for name, r in source.robots.items()
                },
            }
        )
    for robot in runtime.robots:
        source_health = by_name[robot.source]
        state = source_health.robots.get(robot.name)
        robots.append(
            {
                "name": robot.name,
                "source": robot.source,
                "ok": bool(state and state.ok and source_health.live),
                "error": None if state is None else state.error,
                "frames": 0 if state is None else state.frames,
            }
        )
    live = [s["state"] == "connected" for s in sources]
    healthy = all(live) and all(r["ok"] for r in robots) and runtime.cell_error is None
    samples = load_summary(list(by_name.values()))
    # Overloaded is not degraded: every robot still moves, at a reduced rate.
    status = ("overloaded" if samples["overloaded"] else "ok") if healthy else "degraded"
    body = {
        "status": status,
        "samples": samples,
        "time": time.time(),
        "cell": {
            "path": runtime.cell_name,
            "error": runtime.cell_error,
        },
        "sources": sources,
        "robots": robots,
        "viewers": runtime.hub.viewer_count,
        "dropped_frames": runtime.hub.dropped,
        **runtime.report(),
    }
    return JSONResponse(body, status_code=200 if any(live) else 503)
