"""Fault injection for tests and benchmarks: latency, errors, dropped or stalled streams, outages.

Switch faults through ``app[STATE_KEY].faults`` in tests, or over HTTP on the
admin endpoint ``/mock/faults`` (outside the ctrlX paths, so it stays
reachable during an outage).
"""

from __future__ import annotations

import asyncio
import random
from dataclasses import dataclass, field
from typing import Any

from aiohttp import web
from aiohttp.typedefs import Handler

from .problems import request_problem

CTRLX_PREFIXES = ("/automation/", "/identity-manager/")


@dataclass
class Faults:
    """What goes wrong right now; all off by default."""

    latency_s: float = 0.0
    """Added before every ctrlX answer (and before an event stream starts)."""
    error_rate: float = 0.0
    """Share of ctrlX requests answered with a 500 Problem."""
    outage: bool = False
    """Connections to the ctrlX paths are dropped without an answer; open streams end."""
    stall_streams: bool = False
    """Open event streams stay open but send nothing, keepalives included."""
    drops: int = 0
    """Incremented by ``drop_streams``; streams opened before it end."""
    rng: random.Random = field(default_factory=lambda: random.Random(0), repr=False)

    def drop_streams(self) -> None:
        """End every open event stream now (the server closes them cleanly)."""
        self.drops += 1

    def update(self, changes: dict[str, Any]) -> None:
        """Apply ``{"latency_s": ..., "error_rate": ..., "outage": ..., "stall_streams": ...}``."""
        for key in ("latency_s", "error_rate"):
            if key in changes:
                setattr(self, key, max(float(changes[key]), 0.0))
        for key in ("outage", "stall_streams"):
            if key in changes:
                setattr(self, key, bool(changes[key]))

    def as_dict(self) -> dict[str, Any]:
        """The switchable faults, as the admin endpoint shows them."""
        return {
            "latency_s": self.latency_s,
            "error_rate": self.error_rate,
            "outage": self.outage,
            "stall_streams": self.stall_streams,
            "drops": self.drops,
        }


def faults_middleware(faults_of: Any) -> Any:
    """Middleware applying the faults of ``faults_of(app)`` to ctrlX paths."""

    @web.middleware
    async def inject_faults(request: web.Request, handler: Handler) -> web.StreamResponse:
        if not request.path.startswith(CTRLX_PREFIXES):
            return await handler(request)
        faults: Faults = faults_of(request.app)
        if faults.outage:
            # Like a controller that is off: the connection dies without an answer.
            if request.transport is not None:
                request.transport.abort()
            return web.Response(status=503)
        if faults.latency_s > 0.0:
            await asyncio.sleep(faults.latency_s)
        if faults.error_rate > 0.0 and faults.rng.random() < faults.error_rate:
            detail = "injected fault (error_rate)"
            return request_problem(request, 500, "Internal Server Error", detail)
        return await handler(request)

    return inject_faults
