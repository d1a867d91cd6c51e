"""One data-layer stream per source, whatever the number of viewers."""

from __future__ import annotations

import asyncio
import contextlib
import json

import pytest
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
    """Data-layer requests per published sample, from before ``viewers`` viewers connect."""
    async with contextlib.AsyncExitStack() as stack:
        before = counter[0]
        sockets = [await stack.enter_async_context(connect(base + "/ws")) for _ in range(viewers)]
        async with asyncio.timeout(20):
            seq0 = (await frame_seqs(sockets[0], 1))[0]
            await asyncio.gather(*(frame_seqs(ws, 40) for ws in sockets))
            seq1 = (await frame_seqs(sockets[0], 1))[0]
        after = counter[0]
    return (after - before) / (seq1 - seq0)


@pytest.mark.parametrize("mode", ["subscribe", "poll"])
async def test_ten_viewers_cause_the_same_traffic_as_one(mode: str) -> None:
    app = build_app()
    counter = count_requests(app)
    async with running_mock(app) as (_, mock_url):
        settings = Settings(ctrlx_url=mock_url, ctrlx_mode=mode)  # type: ignore[arg-type]
        async with running_server(settings) as base:
            ws_base = base.replace("http", "ws")
            one = await requests_per_sample(ws_base, counter, 1)
            ten = await requests_per_sample(ws_base, counter, 10)
    if mode == "poll":
        assert one > 0.5  # one bulk read per sample
    else:
        assert one < 0.5  # one stream, not a request per sample
    # Were each viewer to cause its own reads or subscription, ten would be far above one.
    assert ten <= one * 1.25 + 0.1, (one, ten)
