"""The FastAPI application: routes, WebSocket and static files around a Runtime."""

from __future__ import annotations

import asyncio
import contextlib
import functools
import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from fastapi.staticfiles import StaticFiles
from starlette.datastructures import State

from ..access import Access
from ..cell import Cell
from ..clearance import ClearanceService
from ..cluster import Replica, broker_settings
from ..coarse import CoarseMeshes
from ..commissioning import Catalog, CellEditor
from ..config import Settings
from ..foxglove import FoxgloveEndpoint
from ..hosts import HostPolicy
from ..loop_pacing import loop_pacer
from ..paths import STATIC_DIR
from ..recording import Recorder
from ..runtime import Runtime
from ..runtime.loop_lag import LoopLag
from ..runtime.reload import follow_cell_file
from ..runtime.startup import configured_cell, source_defaults, with_controller
from . import calibrate, cell_edits, clearance, history, metrics, routes, transformation, ws
from .guards import Gatekeeper, LimitBody
from .headers import SecurityHeaders

log = logging.getLogger(__name__)


def create_app(settings: Settings, cell: Cell | None = None) -> FastAPI:
    """An app that starts its Runtime on startup and stops it on shutdown.

    Without ``cell``, the settings' cell file (or the demo cell) is loaded. A
    cell read from a file is followed: saving the file reloads the cell.
    """

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        start = configured_cell(settings) if cell is None else with_controller(cell, settings)
        broker = broker_settings(settings)
        if broker is None:
            runtime = await Runtime.start(start, source_defaults(settings))
        else:  # a replica of a cluster: its frames come through the broker
            runtime = await Replica.open(start, source_defaults(settings), broker)
        app.state.runtime = runtime
        app.state.editor = CellEditor(
            runtime,
            functools.partial(configured_cell, settings),
            settings.allow_edits,
            _never_edited(settings),
        )
        app.state.catalog = Catalog()
        stop = asyncio.Event()
        watcher = None
        path = runtime.cell.path
        if path is not None:
            load = functools.partial(configured_cell, settings, path)
            watcher = asyncio.create_task(follow_cell_file(runtime, path, load, stop))
        background = await _start_look_back(settings, runtime, app.state)
        app.state.loop_lag = LoopLag()
        loop_pacer().start()
        background.append(asyncio.create_task(app.state.loop_lag.run(), name="loop lag"))
        app.state.clearance = None
        if settings.clearance_m > 0.0:
            app.state.clearance = ClearanceService(runtime.hub, settings.clearance_m)
            check = app.state.clearance.run(lambda: runtime.robots, runtime.newest_values)
            background.append(asyncio.create_task(check, name="clearance"))
        try:
            yield
        finally:
            for task in background:
                task.cancel()
            await asyncio.gather(*background, return_exceptions=True)
            stop.set()
            if watcher is not None:
                watcher.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await watcher
            await runtime.stop()

    app = FastAPI(title="linkview", lifespan=lifespan)
    app.state.max_viewers = settings.max_viewers
    app.state.foxglove_clients = lambda: 0  # Foxglove's clients, once its endpoint serves
    app.state.coarse_meshes = CoarseMeshes()  # the 2D view's link meshes
    token = settings.viewer_token.get_secret_value() if settings.viewer_token else None
    hosts = HostPolicy(settings.host, settings.allow_host)
    app.add_middleware(Gatekeeper, token=token, allowed_origins=settings.allow_origin, hosts=hosts)
    app.add_middleware(LimitBody)
    app.add_middleware(SecurityHeaders, page=STATIC_DIR / "index.html")
    app.add_exception_handler(RequestValidationError, _validation_error)
    app.include_router(routes.router)
    app.include_router(ws.router)
    app.include_router(transformation.router)
    app.include_router(metrics.router)
    app.include_router(history.router)
    app.include_router(clearance.router)
    app.include_router(calibrate.router)
    app.include_router(cell_edits.router)
    app.mount("/static", StaticFiles(directory=STATIC_DIR, check_dir=False), name="static")
    return app


async def _start_look_back(
    settings: Settings, runtime: Runtime, state: State
) -> list[asyncio.Task[None]]:
    """The continuous recording and the Foxglove endpoint, where the settings ask for them.

    ``/ws``'s viewers and Foxglove's clients share ``--max-viewers``: each door counts the
    other's (``state.foxglove_clients`` for ``/ws``).
    """
    tasks = []
    if settings.record is not None:
        recorder = Recorder(runtime.history, lambda: runtime.cell, settings.record)
        tasks.append(asyncio.create_task(recorder.run(), name="recorder"))
    if settings.foxglove_port is not None:
        token = settings.viewer_token.get_secret_value() if settings.viewer_token else None
        access = Access(
            token, settings.allow_origin, HostPolicy(settings.host, settings.allow_host)
        )
        endpoint = FoxgloveEndpoint(
            runtime.history,
            lambda: runtime.cell,
            settings.host,
            settings.foxglove_port,
            access,
            settings.max_viewers,
            others=lambda: runtime.hub.viewer_count,
        )
        try:
            await endpoint.start()
        except Exception as exc:  # a port in use must not keep the viewers from the cell
            log.error(
                "foxglove: cannot serve on %s:%d: %s", settings.host, settings.foxglove_port, exc
            )
            await endpoint.stop()
        else:
            tasks.append(asyncio.create_task(endpoint.run(), name="foxglove"))
            state.foxglove_clients = lambda: endpoint.guard.clients if endpoint.guard else 0
    return tasks


def _never_edited(settings: Settings) -> str | None:
    """Why this server never changes its cell file, whatever ``--allow-edits`` says."""
    if settings.replay is not None:
        return "a recording being replayed is not edited: serve its cell file with --cell FILE"
    if settings.broker is not None:
        return "a cluster's cell is edited in its file, not from the page (each process reloads it)"
    return None


async def _validation_error(request: Request, exc: Exception) -> JSONResponse:
    """422 naming each bad field; the offending input is left out, as NaN is not JSON."""
    assert isinstance(exc, RequestValidationError)
    errors = [{"loc": list(e["loc"]), "msg": e["msg"]} for e in exc.errors()]
    return JSONResponse({"detail": errors}, status_code=422)
