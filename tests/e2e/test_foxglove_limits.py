"""The Foxglove endpoint holds ``/ws``'s rules: who may connect, and what a client may cost.

Clients are the ``websockets`` library speaking Foxglove's WebSocket protocol
(``foxglove.sdk.v1``, as tests/e2e/test_foxglove.py). One server process (token
set, ``--foxglove``) serves the module, with a protocol-2 viewer reading
``/ws`` throughout (tests/e2e/test_limits.py): each attack checks that
viewer's rate against its own quiet rate, and the server's memory.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import re
import socket
import struct
import urllib.request
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import pytest
from websockets.asyncio.client import ClientConnection, connect
from websockets.exceptions import ConnectionClosed, InvalidStatus

from server.config import Settings
from server.foxglove import live
from tests.conftest import free_port, running_server
from tests.e2e.test_limits import AUTH, TOKEN, Server, limits_server

SUBPROTOCOLS: list[Any] = ["foxglove.sdk.v1"]


@dataclass
class Fox:
    """The module's server (``server.attacked()`` checks the /ws viewer) and its endpoint."""

    server: Server
    port: int

    @property
    def url(self) -> str:
        return f"ws://127.0.0.1:{self.port}/"

    def socket(self) -> socket.socket:
        """A connection to the endpoint whose receive buffer is as small as the kernel allows."""
        sock = socket.socket()
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        sock.connect(("127.0.0.1", self.port))
        return sock


@pytest.fixture(scope="module")
def fox(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Fox]:
    port = free_port()
    log = tmp_path_factory.mktemp("fox") / "server.log"
    with limits_server(log, "--foxglove", str(port)) as running:
        yield Fox(running, port)


async def advertised(ws: ClientConnection) -> dict[str, int]:
    """Read serverInfo and the advertisements: topic -> channel id."""
    channels: dict[str, int] = {}
    async with asyncio.timeout(20):
        assert json.loads(await ws.recv())["op"] == "serverInfo"
        while "/scene" not in channels or "/tf" not in channels:
            message = await ws.recv()
            if isinstance(message, str) and json.loads(message)["op"] == "advertise":
                channels.update({c["topic"]: c["id"] for c in json.loads(message)["channels"]})
    return channels


def subscribe(channels: dict[str, int], topics: list[str] | None = None) -> str:
    """Subscribe to ``topics`` (every channel: None); subscription ids are the channel ids."""
    wanted = [channels[t] for t in topics] if topics else list(channels.values())
    subscriptions = [{"id": c, "channelId": c} for c in wanted]
    return json.dumps({"op": "subscribe", "subscriptions": subscriptions})


def unsubscribe(channel: int) -> str:
    return json.dumps({"op": "unsubscribe", "subscriptionIds": [channel]})


async def refused(url: str, **options: Any) -> tuple[int, str]:
    with pytest.raises(InvalidStatus) as refusal:
        async with connect(url, subprotocols=SUBPROTOCOLS, **options):
            pass
    response = refusal.value.response
    return response.status_code, bytes(response.body or b"").decode()


async def test_foreign_origins_hosts_and_missing_tokens_are_refused(fox: Fox) -> None:
    with fox.server.attacked():
        foreign = await refused(fox.url, origin="https://evil.example", additional_headers=AUTH)
        null = await refused(fox.url, origin="null", additional_headers=AUTH)
        cookie = {"Cookie": f"linkview_token={TOKEN}"}  # the page's cookie, sent by a browser
        with_cookie = await refused(
            fox.url, origin="https://evil.example", additional_headers=cookie
        )
        # DNS rebinding: a page at evil.example whose name resolved to 127.0.0.1.
        rebound_url = f"ws://evil.example:{fox.port}/"
        rebound = await refused(rebound_url, sock=fox.socket(), additional_headers=AUTH)
        no_token = await refused(fox.url)
        # The server's own page and a client that is not a browser get in.
        own = fox.url.replace("ws://", "http://").rstrip("/")
        for origin in (own, None):
            async with connect(
                fox.url, subprotocols=SUBPROTOCOLS, origin=origin, additional_headers=AUTH
            ) as ws:
                assert "/tf" in await advertised(ws)
    assert foreign == (403, "cross-origin WebSocket refused\n")
    assert null == with_cookie == foreign
    assert rebound[0] == 403 and "'evil.example' is not served here" in rebound[1]
    assert no_token == (401, "viewer token missing or wrong\n")


async def test_a_message_flood_closes_that_client_with_1008(fox: Fox) -> None:
    with fox.server.attacked():
        async with connect(fox.url, subprotocols=SUBPROTOCOLS, additional_headers=AUTH) as ws:
            await advertised(ws)
            harmless = json.dumps({"op": "unsubscribe", "subscriptionIds": [1]})
            sent = 0
            with pytest.raises(ConnectionClosed) as closed:
                async with asyncio.timeout(20):
                    while True:
                        await ws.send(harmless)
                        sent += 1
                        if sent % 50 == 0:
                            await asyncio.sleep(0)  # let the close arrive
    assert closed.value.rcvd is not None and closed.value.rcvd.code == 1008
    assert "messages per second" in closed.value.rcvd.reason
    # Closed after the burst (100): the sends the client had queued meanwhile are a few hundred.
    assert sent < 5000


def _metric(fox: Fox, name: str) -> float:
    request = urllib.request.Request(fox.server.url + "/metrics", headers=AUTH)
    with urllib.request.urlopen(request, timeout=10) as response:
        text = response.read().decode()
    found = re.search(rf"^{re.escape(name)} ([0-9.e+]+)$", text, re.MULTILINE)
    return float(found.group(1)) if found else 0.0


QUEUED = 'linkview_viewers_closed_total{bound="queued"}'


async def test_subscribers_that_never_read_are_closed_and_their_memory_freed(fox: Fox) -> None:
    clients = 40
    closed_before = _metric(fox, QUEUED)
    with fox.server.attacked() as window:
        silent: list[tuple[ClientConnection, dict[str, int]]] = []
        try:
            for _ in range(clients):
                ws = await connect(
                    fox.url,
                    sock=fox.socket(),
                    subprotocols=SUBPROTOCOLS,
                    additional_headers=AUTH,
                    max_size=None,
                    max_queue=1,  # reads nothing more once one message waits
                )
                channels = await advertised(ws)
                await ws.send(subscribe(channels))
                silent.append((ws, channels))
            peak = fox.server.rss_mib()
            async with asyncio.timeout(60):
                while _metric(fox, QUEUED) - closed_before < clients:
                    # Each subscribe to /scene asks for the meshes (1.3 MB) again, unread.
                    for ws, channels in silent:
                        with contextlib.suppress(ConnectionClosed):
                            await ws.send(unsubscribe(channels["/scene"]))
                            await ws.send(subscribe(channels, ["/scene"]))
                    await asyncio.sleep(0.5)
                    peak = max(peak, fox.server.rss_mib())
        finally:
            for ws, _ in silent:
                ws.transport.abort()
    # Each costs what waits for it (256 KiB) and its connections, not the meshes it asked for
    # again and again: under 1 MiB (before the fix: +646 MB for 40, kept).
    bound = clients * 1.0
    grown = peak - window.rss_before
    assert grown < bound, f"the server grew by {grown:.0f} MiB"


async def test_no_more_clients_than_viewers_are_let_in() -> None:
    port = free_port()
    url = f"ws://127.0.0.1:{port}/"
    async with running_server(Settings(foxglove_port=port, max_viewers=2)):
        async with connect(url, subprotocols=SUBPROTOCOLS) as a:
            async with connect(url, subprotocols=SUBPROTOCOLS) as b:
                await advertised(a)
                await advertised(b)
                assert await refused(url) == (503, "too many viewers; try again later\n")
        async with connect(url, subprotocols=SUBPROTOCOLS) as again:  # room once they left
            await advertised(again)


async def test_foxglove_clients_and_page_viewers_share_the_viewer_cap() -> None:
    port = free_port()
    fox_url = f"ws://127.0.0.1:{port}/"
    async with running_server(Settings(foxglove_port=port, max_viewers=2)) as base:
        page_url = base.replace("http", "ws") + "/ws"
        async with connect(page_url) as viewer, connect(fox_url, subprotocols=SUBPROTOCOLS) as fox:
            await viewer.recv()  # hello: a viewer of the page
            await advertised(fox)
            # Two of two: a third is refused at either door.
            assert await refused(fox_url) == (503, "too many viewers; try again later\n")
            with pytest.raises(InvalidStatus) as page_refusal:
                async with connect(page_url):
                    pass
            assert page_refusal.value.response.status_code == 503


async def test_the_meshes_are_encoded_once_and_sent_to_each_subscriber_alone(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    encoded: list[bytes] = []
    real = live.scene_update

    def counting(robots: Any, t: float) -> bytes:
        encoded.append(real(robots, t))
        return encoded[-1]

    monkeypatch.setattr(live, "scene_update", counting)
    port = free_port()
    url = f"ws://127.0.0.1:{port}/"
    scenes: dict[str, list[bytes]] = {"watcher": [], "toggler": []}

    async def collect(name: str, ws: ClientConnection, subscription: int) -> None:
        with contextlib.suppress(ConnectionClosed):
            async for message in ws:
                if isinstance(message, bytes):
                    opcode, sub = struct.unpack_from("<BI", message)
                    if (opcode, sub) == (1, subscription):
                        scenes[name].append(message[13:])

    async with running_server(Settings(foxglove_port=port)):
        async with (
            connect(url, subprotocols=SUBPROTOCOLS, max_size=None) as watcher,
            connect(url, subprotocols=SUBPROTOCOLS, max_size=None) as toggler,
        ):
            channels = await advertised(watcher)
            await advertised(toggler)
            scene = channels["/scene"]
            readers = [
                asyncio.create_task(collect("watcher", watcher, scene)),
                asyncio.create_task(collect("toggler", toggler, scene)),
            ]
            await watcher.send(subscribe(channels, ["/scene"]))
            # Subscribing to /scene again and again: 5 times a second for 6 s (within budget).
            for _ in range(30):
                await toggler.send(subscribe(channels, ["/scene"]))
                await toggler.send(unsubscribe(scene))
                await asyncio.sleep(1 / 5)
            async with asyncio.timeout(30):
                while len(scenes["toggler"]) < 30 or not scenes["watcher"]:
                    await asyncio.sleep(0.1)
            await asyncio.sleep(0.5)
            for reader in readers:
                reader.cancel()
    assert len(encoded) == 1, f"the scene was encoded {len(encoded)} times"
    assert scenes["watcher"] == encoded, "the watcher got the meshes once, as encoded"
    assert scenes["toggler"] == encoded * 30, "each of the toggler's subscribes got them"
