"""The FastAPI application: routes, WebSocket and static files around a Runtime."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI
from fastapi.staticfiles import StaticFiles

from ..cell import Robot
from ..config import Settings
from ..runtime import Runtime
from . import routes, ws


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
    app.include_router(routes.router)
    app.include_router(ws.router)
    app.mount("/static", StaticFiles(directory=routes.STATIC_DIR, check_dir=False), name="static")
    app.mount("/assets", StaticFiles(directory=routes.ASSETS_DIR, check_dir=False), name="assets")
    return app
