"""Shared pieces of the client and mock tests: a mock on a free loopback port, traffic logs."""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aiohttp import web
from aiohttp.typedefs import Handler

from server.ctrlx import Credentials, DataLayerClient, Sample
from server.mock_ctrlx import STATE_KEY, MockCertificate, MockState, build_app, make_certificate
from server.mock_ctrlx import serve as serve_mock

USER = Credentials("boschrexroth", "boschrexroth")
KIN12 = [f"motion/axs/kin12_a{i}/state/values/actual/pos" for i in (0, 1)]
IIWA = [f"motion/axs/iiwa_a{i}/state/values/actual/pos" for i in range(1, 8)]


@dataclass
class Mock:
    """A running mock: its app state, base URL, request log and (with TLS) its certificate."""

    app: web.Application
    url: str
    log: list[tuple[str, str, int]] = field(default_factory=list)
    """(method, raw path, status) of every request, in arrival order (streams when they start)."""
    cert: MockCertificate | None = None

    @property
    def state(self) -> MockState:
        return self.app[STATE_KEY]

    def count(self, method: str, path_start: str, status: int | None = None) -> int:
        """Requests so far with this method whose path starts with ``path_start``."""
        return sum(
            1
            for m, p, s in self.log
            if m == method and p.startswith(path_start) and (status is None or s == status)
        )


def _recorder(log: list[tuple[str, str, int]]) -> Any:
    @web.middleware
    async def record(request: web.Request, handler: Handler) -> web.StreamResponse:
        response = await handler(request)
        log.append((request.method, request.rel_url.raw_path, response.status))
        return response

    return record


@asynccontextmanager
async def running(
    app: web.Application | None = None, *, tls_dir: Path | None = None, **options: Any
) -> AsyncIterator[Mock]:
    """A mock ctrlX (``build_app(**options)`` unless ``app``) on a free loopback port."""
    app = app if app is not None else build_app(**options)
    log: list[tuple[str, str, int]] = []
    # Outermost, so it records every answer, injected faults and 401s included.
    app.middlewares.insert(0, _recorder(log))
    cert = make_certificate(tls_dir) if tls_dir is not None else None
    runner, url = await serve_mock(
        app, "127.0.0.1", 0, cert.server_context() if cert is not None else None
    )
    try:
        yield Mock(app, url, log, cert)
    finally:
        await runner.cleanup()


async def collect(
    samples: AsyncIterator[Sample], duration_s: float, limit_s: float = 20.0, at_least: int = 1
) -> list[Sample]:
    """Samples received during ``duration_s``, and ``at_least`` that many however long they
    take on a busy machine (the test fails after ``limit_s``)."""
    out: list[Sample] = []
    end = time.monotonic() + duration_s
    async with asyncio.timeout(limit_s):
        async for sample in samples:
            out.append(sample)
            if time.monotonic() >= end and len(out) >= at_least:
                break
    await samples.aclose()  # type: ignore[attr-defined]
    return out


def client(url: str, **options: Any) -> DataLayerClient:
    """A client with the mock's default user."""
    return DataLayerClient(url, options.pop("credentials", USER), **options)


def max_gap(samples: list[Sample]) -> float:
    """Largest step between consecutive sample times (data-layer clock)."""
    times = [s.t_source for s in samples]
    return max((b - a for a, b in zip(times, times[1:], strict=False)), default=0.0)
