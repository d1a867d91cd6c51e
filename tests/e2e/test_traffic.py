"""One data-layer stream per source, whatever the number of viewers."""

from __future__ import annotations

import asyncio
import contextlib
import json

from aiohttp import web
from websockets.asyncio.client import ClientConnection, connect

from server.config import Settings
from server.mock_ctrlx import build_app
from tests.conftest import running_mock, running_server


def count_requests(app: web.Application) -> list[int]:
    """Install a counter of data-layer requests on a mock app (before it starts)."""
    counter = [0]

    @web.middleware
    async def counting(request: web.Request, handler: web.RequestHandler) -> web.StreamResponse:
        if request.path.startswith("/automation/"):
            counter[0] += 1
        return await handler(request)

    app.middlewares.insert(0, counting)
    return counter


async def frame_seqs(ws: ClientConnection, n: int) -> list[int]:
    """Sequence numbers of the next ``n`` kin12 frames."""
    seqs: list[int] = []
    while len(seqs) < n:
        msg = json.loads(await ws.recv())
        if msg["type"] == "frame" and msg["robot"] == "kin12":
            seqs.append(msg["seq"])
    return seqs


async def requests_per_sample(base: str, counter: list[int], viewers: int) -> float:
    """Data-layer requests per published sample while ``viewers`` viewers watch."""
    async with contextlib.AsyncExitStack() as stack:
        sockets = [await stack.enter_async_context(connect(base + "/ws")) for _ in range(viewers)]
        async with asyncio.timeout(20):
            await asyncio.gather(*(frame_seqs(ws, 3) for ws in sockets))
            before, seq0 = counter[0], (await frame_seqs(sockets[0], 1))[0]
            await asyncio.gather(*(frame_seqs(ws, 25) for ws in sockets))
            after, seq1 = counter[0], (await frame_seqs(sockets[0], 1))[0]
    return (after - before) / (seq1 - seq0)


async def test_ten_viewers_cause_the_same_traffic_as_one() -> None:
    app = build_app()
    counter = count_requests(app)
    async with running_mock(app) as (_, mock_url):
        async with running_server(Settings(ctrlx_url=mock_url)) as base:
            ws_base = base.replace("http", "ws")
            one = await requests_per_sample(ws_base, counter, 1)
            ten = await requests_per_sample(ws_base, counter, 10)
    assert one > 0
    # Up to one sample's worth of requests may fall either side of the window edges.
    assert abs(ten - one) <= max(0.25 * one, 1.0)
