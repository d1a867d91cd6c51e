"""A viewer that stops reading never slows the others down."""

from __future__ import annotations

import asyncio
import json
import socket

import aiohttp
from websockets.asyncio.client import connect

from server.config import Settings
from tests.conftest import running_mock, running_server


async def frames_dropped(http: aiohttp.ClientSession, base: str) -> float:
    """Messages the server skipped for slow viewers so far (coalesced, newest kept)."""
    async with http.get(base + "/metrics") as resp:
        text = await resp.text()
    (line,) = [
        line for line in text.splitlines() if line.startswith("linkview_frames_dropped_total")
    ]
    return float(line.rsplit(" ", 1)[1])


async def test_a_stalled_viewer_is_coalesced_while_a_reading_viewer_streams_on() -> None:
    async with (
        running_mock() as (_, mock_url),
        running_server(Settings(ctrlx_url=mock_url)) as base,
        aiohttp.ClientSession() as http,
    ):
        host, port = base.removeprefix("http://").split(":")
        # A tiny receive window and segment size (set before connecting: the server sizes
        # its send buffer from the segments) make the server's sends back up in a second or
        # two, not after the megabytes a loopback connection buffers by default.
        stalled_sock = socket.socket()
        stalled_sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        stalled_sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_MAXSEG, 536)
        stalled_sock.connect((host, int(port)))
        stalled_url = base.replace("http", "ws") + "/ws"
        async with connect(stalled_url, sock=stalled_sock, close_timeout=0.5) as stalled:
            await stalled.recv()  # hello, then never read again
            async with asyncio.timeout(20):  # backed up: its frames are skipped, not queued
                while await frames_dropped(http, base) == 0:
                    await asyncio.sleep(0.05)
            async with connect(base.replace("http", "ws") + "/ws") as reader:
                dropped = await frames_dropped(http, base)
                seqs: list[int] = []
                async with asyncio.timeout(20):
                    while len(seqs) < 100:
                        msg = json.loads(await reader.recv())
                        if msg["type"] == "frame" and msg["robot"] == "kin12":
                            seqs.append(msg["seq"])
                dropped = await frames_dropped(http, base) - dropped
                async with http.get(base + "/api/health") as resp:
                    health = await resp.json()
        assert health["viewers"] == 2
    # The reader's stream went on, in order, while the stalled viewer's was coalesced.
    # (Whether it also got every sample depends on how fast this machine lets it read:
    # bench/viewers.py measures that.)
    assert seqs == sorted(set(seqs)), seqs
    assert dropped > 0, "the stalled viewer was no longer skipped"
