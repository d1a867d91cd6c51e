"""The Foxglove endpoint's door: ``/ws``'s rules in front of a server that has none of its own.

foxglove-sdk's WebSocket server cannot refuse a client (its ServerListener
hears of clients only once they subscribe) and bounds nothing per client
but its message backlog. So it listens on a loopback port only this process
knows, and this guard listens where the user asked, as a WebSocket server of
its own (the ``websockets`` library) relaying messages both ways:

* a client is admitted only as ``/ws`` admits a viewer (``access.Access``:
  its Host, its Origin, the viewer token) and while fewer than
  ``--max-viewers`` are connected, its clients and ``/ws``'s viewers together;
* what it sends is paid from a ``flood.MessageBudget`` (pings and pongs
  included) and may be at most MAX_CLIENT_MESSAGE bytes; past either it is
  closed with 1008 (1009);
* what the SDK sends it is read at once, whatever the client does: a data
  message (binary) is written only while less than WRITE_BELOW bytes wait
  for the client, else dropped, as ``/ws`` drops the frames of a slow
  viewer; control messages (text) are always written. A client that has
  taken nothing for ``flood.SEND_TIMEOUT_S``, or for which more than
  ``flood.MAX_QUEUED_BYTES`` wait, is closed. So a client costs at most
  WRITE_BELOW bytes and the one message written last, however long it does
  not read;
* ``/scene`` (the meshes, the one large message) is sent by the guard itself,
  to the subscribing client alone, from one copy shared by all (``scene``).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable
from urllib.parse import urlsplit

from websockets.asyncio.client import ClientConnection, connect
from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.datastructures import Headers
from websockets.exceptions import ConnectionClosed, InvalidHandshake
from websockets.frames import CloseCode
from websockets.http11 import Request, Response
from websockets.protocol import Event
from websockets.typing import Subprotocol

from .. import flood
from ..access import Access, token_given
from ..flood import MAX_QUEUED_BYTES, MESSAGES_PER_S, SEND_TIMEOUT_S, MessageBudget
from .scene import SceneBytes, Subscriptions, send_scene

log = logging.getLogger(__name__)

SUBPROTOCOL = Subprotocol("foxglove.sdk.v1")
"""The only name foxglove-sdk's server accepts for the protocol (``foxglove.websocket.v1``)."""
MAX_CLIENT_MESSAGE = 64 * 1024
"""A client's subscribe and other requests (a subscription of 1000 channels: about 40 KiB)."""
UPSTREAM_QUEUE = 4
"""Messages read ahead from the SDK's server for one client (it is read at once anyway)."""
WRITE_BELOW = 256 * 1024
"""A data message is written to a client only while fewer bytes than this wait for it."""
CLOSE_TIMEOUT_S = 2.0
"""How long a closing handshake may take (both sides are loopback or a viewer's browser)."""


class _Bounded(ServerConnection):
    """A connection that pays for every frame it receives and must read its pongs."""

    budget: MessageBudget | None = None

    def process_event(self, event: Event) -> None:
        if self.request is None or self.budget is None:  # the handshake
            super().process_event(event)
            return
        if self.protocol.close_expected() or self.transport.is_closing():
            return  # closing: what it still sends is dropped unread
        if not self.budget.spend():
            self._close_for("messages", f"sends more than {MESSAGES_PER_S:g} messages per second")
            return
        if self.transport.get_write_buffer_size() > MAX_QUEUED_BYTES:
            self._close_for("queued", "does not read what it asked for (pongs)")
            return
        super().process_event(event)

    def _close_for(self, bound: str, reason: str) -> None:
        flood.closed[bound] += 1
        log.warning("foxglove client %s closed: it %s", _peer(self), reason)
        if self.transport.get_write_buffer_size() > MAX_QUEUED_BYTES:
            self.transport.abort()  # behind a backlog the close frame would never arrive
            return
        self.protocol.fail(CloseCode.POLICY_VIOLATION, f"client {reason}"[:120])
        self.send_data()


def _peer(connection: ServerConnection) -> str:
    address = connection.remote_address
    return "?" if not address else f"{address[0]}:{address[1]}"


def _one(headers: Headers, name: str) -> str | None:
    """The header ``name``; ValueError if it is there more than once."""
    values = headers.get_all(name)
    if len(values) > 1:
        raise ValueError(f"{len(values)} {name} headers")
    return values[0] if values else None


class Guard:
    """Listens on ``host:port`` and relays the clients it admits to ``127.0.0.1:upstream``."""

    def __init__(
        self,
        access: Access,
        upstream_port: int,
        max_clients: int,
        scene: SceneBytes | None = None,
        others: Callable[[], int] = lambda: 0,
    ) -> None:
        self.access = access
        self.scene = scene
        self.upstream_port = upstream_port
        self.max_clients = max_clients
        self.others = others
        """Viewers of the process's other doors (``/ws``): they share ``max_clients``."""
        self.refused = 0
        self.dropped = 0
        """Data messages not written to clients that did not read them."""
        self._server: Server | None = None

    async def start(self, host: str, port: int) -> int:
        """Start listening; returns the port (useful with 0)."""
        self._server = await serve(
            self._relay,
            host,
            port,
            subprotocols=[SUBPROTOCOL],
            process_request=self._admit,
            create_connection=_Bounded,
            compression=None,
            max_size=MAX_CLIENT_MESSAGE,
            max_queue=UPSTREAM_QUEUE,
            close_timeout=CLOSE_TIMEOUT_S,
            write_limit=MAX_QUEUED_BYTES,  # sends wait only past it: what waits is ours to bound
        )
        return int(next(iter(self._server.sockets)).getsockname()[1])

    @property
    def clients(self) -> int:
        """Clients connected now. Counted from the connections still open, not from the
        relays still running: a client that has left frees its place at once, even while
        its relay is still closing the SDK's side."""
        return 0 if self._server is None else len(self._server.connections)

    async def stop(self) -> None:
        """Stop listening and close every connection; a client that does not answer the
        closing handshake within CLOSE_TIMEOUT_S is cut, so that it cannot hold up a
        shutdown."""
        if self._server is not None:
            self._server.close()
            try:
                async with asyncio.timeout(2 * CLOSE_TIMEOUT_S):
                    await self._server.wait_closed()
            except TimeoutError:
                for connection in self._server.all_connections:
                    connection.transport.abort()
            self._server = None

    def _admit(self, connection: ServerConnection, request: Request) -> Response | None:
        """Refuse a client ``/ws`` would refuse, with the same status and reason."""
        refusal = self._refusal(request)
        if refusal is None:
            return None
        self.refused += 1
        status, reason = refusal
        return connection.respond(status, reason + "\n")

    def _refusal(self, request: Request) -> tuple[int, str] | None:
        try:
            host = _one(request.headers, "Host")
            origin = _one(request.headers, "Origin")
            authorization = _one(request.headers, "Authorization")
        except ValueError as exc:
            return 400, str(exc)
        refusal = self.access.host_refusal(host)
        if refusal is not None:
            return 403, refusal
        if not self.access.origin_ok(origin, host, secure=False):
            return 403, "cross-origin WebSocket refused"
        cookie = "; ".join(request.headers.get_all("Cookie"))
        given, _ = token_given(urlsplit(request.path).query, authorization, cookie)
        if not self.access.token_ok(given):
            return 401, "viewer token missing or wrong"
        if self.clients + self.others() >= self.max_clients:
            return 503, "too many viewers; try again later"
        return None

    async def _relay(self, client: ServerConnection) -> None:
        """Relay one admitted client's messages to the SDK's server and back."""
        assert isinstance(client, _Bounded)
        client.budget = MessageBudget()
        try:
            async with connect(
                f"ws://127.0.0.1:{self.upstream_port}/",
                subprotocols=[SUBPROTOCOL],
                compression=None,
                max_size=None,  # meshes: the SDK's server is ours
                max_queue=UPSTREAM_QUEUE,
                close_timeout=CLOSE_TIMEOUT_S,
            ) as upstream:
                await self._both_ways(client, upstream)
        except (OSError, InvalidHandshake, TimeoutError) as exc:
            log.error("foxglove endpoint: cannot reach the SDK's server: %s", exc)
            await client.close(CloseCode.INTERNAL_ERROR, "the Foxglove server is not available")

    async def _both_ways(self, client: ServerConnection, upstream: ClientConnection) -> None:
        """Copy messages until either side closes; a client that does not read is closed."""
        subscriptions = Subscriptions()

        async def down() -> None:
            loop = asyncio.get_running_loop()
            taken_at = loop.time()
            async for message in upstream:
                if isinstance(message, str):
                    subscriptions.server_said(message)
                waiting = client.transport.get_write_buffer_size()
                if isinstance(message, bytes) and waiting >= WRITE_BELOW:
                    self.dropped += 1
                    if loop.time() - taken_at > SEND_TIMEOUT_S:
                        _closed_for_not_reading(client)
                        return
                    continue
                try:
                    async with asyncio.timeout(SEND_TIMEOUT_S):
                        await client.send(message)  # waits only past MAX_QUEUED_BYTES
                except TimeoutError:
                    _closed_for_not_reading(client)
                    return
                if waiting < WRITE_BELOW:
                    taken_at = loop.time()  # what waited before has gone out

        async def up() -> None:
            async for message in client:
                await upstream.send(message)
                if isinstance(message, str) and self.scene is not None:
                    for subscription in subscriptions.client_asked(message):
                        await self._send_scene(client, subscription)

        tasks = [asyncio.create_task(down()), asyncio.create_task(up())]
        try:
            await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for task in tasks:
                task.cancel()
            for task in tasks:
                with contextlib.suppress(asyncio.CancelledError, ConnectionClosed):
                    await task

    async def _send_scene(self, client: ServerConnection, subscription: int) -> None:
        assert self.scene is not None
        scene = await self.scene()
        if scene is None:
            return
        try:
            await send_scene(client, subscription, scene, WRITE_BELOW, SEND_TIMEOUT_S)
        except TimeoutError:
            _closed_for_not_reading(client)


def _closed_for_not_reading(client: ServerConnection) -> None:
    flood.closed["queued"] += 1
    log.warning(
        "foxglove client %s closed: it took nothing for %.0f s", _peer(client), SEND_TIMEOUT_S
    )
    client.transport.abort()  # what waits for it goes with it
