"""The FastAPI application: routes, WebSocket and static files around a Runtime."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from fastapi.staticfiles import StaticFiles

from ..cell import Robot
from ..config import Settings
from ..runtime import Runtime
from . import routes, transformation, ws


def create_app(settings: Settings, robots: list[Robot] | None = None) -> FastAPI:
    """An app that starts its Runtime (mock, acquisition) on startup and stops it on shutdown."""

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        app.state.runtime = await Runtime.start(settings, robots)
        try:
            yield
        finally:
            await app.state.runtime.stop()

    app = FastAPI(title="linkview", lifespan=lifespan)
    app.add_exception_handler(RequestValidationError, _validation_error)
    app.include_router(routes.router)
    app.include_router(ws.router)
    app.include_router(transformation.router)
    app.mount("/static", StaticFiles(directory=routes.STATIC_DIR, check_dir=False), name="static")
    app.mount("/assets", StaticFiles(directory=routes.ASSETS_DIR, check_dir=False), name="assets")
    return app


async def _validation_error(request: Request, exc: Exception) -> JSONResponse:
    """422 naming each bad field; the offending input is left out, as NaN is not JSON."""
    assert isinstance(exc, RequestValidationError)
    errors = [{"loc": list(e["loc"]), "msg": e["msg"]} for e in exc.errors()]
    return JSONResponse({"detail": errors}, status_code=422)
