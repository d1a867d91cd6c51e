"""A viewer that stops reading never slows the others down."""

from __future__ import annotations

import asyncio
import json
import socket

import aiohttp
from websockets.asyncio.client import connect

from server.config import Settings
from tests.conftest import running_mock, running_server


async def test_stalled_viewer_does_not_slow_a_reading_viewer() -> None:
    async with (
        running_mock() as (_, mock_url),
        running_server(Settings(ctrlx_url=mock_url)) as base,
    ):
        host, port = base.removeprefix("http://").split(":")
        stalled_sock = socket.create_connection((host, int(port)))
        # A tiny receive window makes the server's sends to it back up quickly.
        stalled_sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        stalled_url = base.replace("http", "ws") + "/ws"
        async with connect(stalled_url, sock=stalled_sock, close_timeout=0.5) as stalled:
            await stalled.recv()  # hello, then never read again
            async with connect(base.replace("http", "ws") + "/ws") as reader:
                seqs: list[int] = []
                async with asyncio.timeout(20):
                    while len(seqs) < 100:
                        msg = json.loads(await reader.recv())
                        if msg["type"] == "frame" and msg["robot"] == "kin12":
                            seqs.append(msg["seq"])
                async with aiohttp.ClientSession() as http:
                    async with http.get(base + "/api/health") as resp:
                        health = await resp.json()
        assert health["viewers"] == 2
    # The reading viewer keeps up: every sample reaches it, none coalesced away.
    gaps = [b - a for a, b in zip(seqs, seqs[1:], strict=False)]
    assert sum(g != 1 for g in gaps) <= 2, gaps
