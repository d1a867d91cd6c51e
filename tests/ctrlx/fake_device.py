"""A ctrlX data layer that misbehaves on request: for fault-injection tests and benchmarks.

It serves the demo cell's joint nodes (login, bulk reads, subscriptions,
single reads) like a plain device, until ``device.behaviour`` says otherwise:
a skewed clock, odd tokens, hostile login answers, broken event streams,
endless bodies, NaN literals, HTML pages, stalls. Switch faults by assigning
fields of ``device.behaviour`` while it runs; ``device.heal()`` ends them.
"""

from __future__ import annotations

import asyncio
import contextlib
import secrets
import socket
import struct
import time
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from typing import Any, Literal

import jwt
import orjson
from aiohttp import web
from aiohttp.typedefs import Handler

from server.cell import load_cell
from server.ctrlx import filetime_from_unix
from server.mock_ctrlx import Machine
from server.paths import DEMO_CELL

TOKEN_PATH = "/identity-manager/api/v2/auth/token"
DL = "/automation/api/v2"
NODES = sorted({n for robot in load_cell(DEMO_CELL).robots for n in robot.nodes})
NAN_NODE = "motion/axs/pos_turn/state/values/actual/pos"
"""The node NaN faults spoil: only the positioner reads it."""
STALL_S = 10.0

LoginAnswer = Literal[
    "ok",
    "500",
    "text_token",  # 200 text/plain: the bare token
    "echo_password",  # 200 JSON echoing name and password, no token
    "html",  # 200 text/html holding the token and the password
    "problem_token",  # 500 Problem whose detail holds a valid token
    "problem_password",  # 401 Problem whose detail quotes the password
    "unsendable",  # 201 JSON with a token no header can carry
]
EventsAnswer = Literal["ok", "refuse", "endless_line", "endless_data", "junk", "reset"]
BulkAnswer = Literal["ok", "refuse", "endless"]
NanKind = Literal["NaN", "Infinity", '"nan"']


@dataclass
class Behaviour:
    """What the device does now; the defaults are a well-behaved device."""

    login: LoginAnswer = "ok"
    clock_offset_s: float = 0.0
    """The device's clock minus ours: negative when it is behind."""
    lifetime_s: float | None = 3600.0
    """exp - iat of issued tokens; None: tokens carry no exp."""
    exp: float | None = None
    """A fixed exp for every token (e.g. 1000.0: far in the past), overriding lifetime_s."""
    check_exp: bool = True
    """Reject tokens whose exp passed on the device's clock."""
    events: EventsAnswer = "ok"
    bulk: BulkAnswer = "ok"
    nan: NanKind | None = None
    """NAN_NODE's value in every answer: a NaN or Infinity literal, or the string "nan"."""
    html: bool = False
    """Every data-layer request (not the login) gets an HTML page."""
    stall: bool = False
    """Every request hangs without a byte (up to STALL_S); open streams fall silent."""
    data_problem_token: bool = False
    """Every data-layer request gets a 403 Problem whose detail quotes the caller's token."""


@dataclass
class Counts:
    """What the device saw."""

    login_attempts: int = 0
    login_times: list[float] = field(default_factory=list)
    """When each login attempt arrived (our monotonic clock, s)."""
    logins: int = 0
    """Tokens issued (successful logins)."""
    rejected: int = 0
    """401 answers to data-layer requests."""
    stream_opens: int = 0
    """Event streams served (refused ones not counted)."""
    subscriptions: int = 0
    refusals: int = 0
    """Subscription and bulk requests answered 404 (or 405) as a refused service."""
    bulk_reads: int = 0
    """Bulk reads answered (refused ones not counted)."""
    node_reads: int = 0


@dataclass
class FakeDevice:
    """The device: its users, its behaviour, what it issued and saw."""

    user: str = "operator"
    password: str = field(default="Pw-" + secrets.token_hex(8), repr=False)
    behaviour: Behaviour = field(default_factory=Behaviour)
    counts: Counts = field(default_factory=Counts)
    issued: list[str] = field(default_factory=list, repr=False)
    """Every token ever issued (for the secret scans); only ``_valid`` ones are accepted."""
    _valid: set[str] = field(default_factory=set, repr=False)
    machine: Machine = field(default_factory=Machine)
    _key: bytes = field(default_factory=lambda: secrets.token_bytes(32), repr=False)
    _healed: asyncio.Event = field(default_factory=asyncio.Event, repr=False)

    def secrets(self) -> list[str]:
        """Every text that must never show: the password and every token issued."""
        return [self.password, *self.issued]

    def heal(self) -> None:
        """Behave well from now on (stalled requests are released)."""
        self.behaviour = Behaviour()
        self._healed.set()

    def revoke_all(self) -> None:
        """Reject every token issued so far: clients must log in again."""
        self._valid.clear()

    def now(self) -> float:
        """The device's clock."""
        return time.time() + self.behaviour.clock_offset_s

    def app(self) -> web.Application:
        """The aiohttp application."""
        app = web.Application(middlewares=[self._stalls, self._auth])
        app.router.add_post(TOKEN_PATH, self._login)
        app.router.add_delete(TOKEN_PATH, self._logout)
        app.router.add_put(DL + "/bulk", self._bulk)
        app.router.add_post(DL + "/events", self._subscribe)
        app.router.add_get(DL + "/events/{id}", self._stream)
        app.router.add_delete(DL + "/events/{id}", self._unsubscribe)
        app.router.add_get(DL + "/nodes/{path:.+}", self._read)
        return app

    # -- identity manager ------------------------------------------------------

    def _issue(self) -> str:
        b, now = self.behaviour, self.now()
        claims: dict[str, Any] = {"sub": self.user, "iat": now, "jti": secrets.token_hex(8)}
        if b.exp is not None:
            claims["exp"] = b.exp
        elif b.lifetime_s is not None:
            claims["exp"] = now + b.lifetime_s
        token = jwt.encode(claims, self._key, algorithm="HS256")
        self.issued.append(token)
        self._valid.add(token)
        return token

    async def _login(self, request: web.Request) -> web.StreamResponse:
        self.counts.login_attempts += 1
        self.counts.login_times.append(time.monotonic())
        body = await request.json()
        answer = self.behaviour.login
        if answer == "500":
            return _problem(500, "Internal Server Error", "identity manager not ready")
        if answer == "echo_password":
            return web.json_response({"name": body.get("name"), "password": body.get("password")})
        if answer == "problem_password":
            return _problem(401, "Unauthorized", f"password '{self.password}' is not accepted")
        if (body.get("name"), body.get("password")) != (self.user, self.password):
            return _problem(401, "Unauthorized", "wrong user name or password", TOKEN_PATH)
        token = self._issue()
        if answer == "text_token":
            return web.Response(text=token, content_type="text/plain")
        if answer == "html":
            page = f"<html><body><p>{token}</p><p>{self.password}</p></body></html>"
            return web.Response(text=page, content_type="text/html")
        if answer == "problem_token":
            return _problem(500, "Internal Server Error", f"could not store token {token}")
        if answer == "unsendable":
            token = token[:20] + "\r\nX-Evil: 1"
        self.counts.logins += 1
        return web.json_response({"access_token": token, "token_type": "Bearer"}, status=201)

    async def _logout(self, request: web.Request) -> web.Response:
        return web.Response(status=204)

    @web.middleware
    async def _auth(self, request: web.Request, handler: Handler) -> web.StreamResponse:
        if not request.path.startswith("/automation/"):
            return await handler(request)
        header = request.headers.get("Authorization", "")
        token = header[7:] if header.startswith("Bearer ") else ""
        if token not in self._valid:
            self.counts.rejected += 1
            return _problem(401, "Unauthorized", "the token is not valid", request.path)
        # Times are the device's to judge, on its own clock (``now``), not the host's.
        unchecked = {"verify_exp": False, "verify_iat": False, "verify_nbf": False}
        claims = jwt.decode(token, self._key, algorithms=["HS256"], options=unchecked)
        if self.behaviour.check_exp and "exp" in claims and claims["exp"] <= self.now():
            self.counts.rejected += 1
            return _problem(401, "Unauthorized", "the token has expired", request.path)
        if self.behaviour.data_problem_token:
            return _problem(403, "Forbidden", f"token {token} lacks a scope", request.path)
        if self.behaviour.html:
            page = "<html><head><title>Welcome</title></head><body>router setup</body></html>"
            return web.Response(text=page, content_type="text/html")
        return await handler(request)

    @web.middleware
    async def _stalls(self, request: web.Request, handler: Handler) -> web.StreamResponse:
        if self.behaviour.stall:
            self._healed.clear()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._healed.wait(), STALL_S)
        return await handler(request)

    # -- data layer ------------------------------------------------------------

    def _values(self) -> tuple[int, dict[str, bytes]]:
        """FILETIME now and every node's value as JSON text (NaN faults applied)."""
        t = self.now()
        snapshot = self.machine.snapshot(t)
        values = {n: orjson.dumps(snapshot[n.split("/")[2]]) for n in NODES}
        if self.behaviour.nan is not None:
            values[NAN_NODE] = self.behaviour.nan.encode()
        return filetime_from_unix(t), values

    async def _bulk(self, request: web.Request) -> web.StreamResponse:
        if self.behaviour.bulk == "refuse":
            self.counts.refusals += 1
            return _problem(404, "Not Found", "no such service", request.path)
        self.counts.bulk_reads += 1
        if self.behaviour.bulk == "endless":
            still = lambda: self.behaviour.bulk == "endless"  # noqa: E731
            return await _endless(request, "application/json", b"[" + b" " * 65536, still)
        items = await request.json()
        stamp, values = self._values()
        entries = [
            b'{"address":%s,"timestamp":%d,"result":"DL_OK","type":"double","value":%s}'
            % (orjson.dumps(i["address"]), stamp, values.get(i["address"], b"0.0"))
            for i in items
        ]
        return web.Response(body=b"[" + b",".join(entries) + b"]", content_type="application/json")

    async def _read(self, request: web.Request) -> web.Response:
        self.counts.node_reads += 1
        node = request.match_info["path"]
        _, values = self._values()
        if node not in values:
            return _problem(404, "DL_INVALID_ADDRESS", f"no node {node}", request.path)
        body = b'{"type":"double","value":%s}' % values[node]
        return web.Response(body=body, content_type="application/json")

    async def _subscribe(self, request: web.Request) -> web.Response:
        if self.behaviour.events == "refuse":
            self.counts.refusals += 1
            return _problem(404, "Not Found", "no such service", request.path)
        self.counts.subscriptions += 1
        return web.Response(status=201)

    async def _unsubscribe(self, request: web.Request) -> web.Response:
        return web.Response(status=200)

    async def _stream(self, request: web.Request) -> web.StreamResponse:
        answer = self.behaviour.events
        if answer == "refuse":
            return _problem(404, "Not Found", "no such service", request.path)
        self.counts.stream_opens += 1
        still = lambda: self.behaviour.events == answer  # noqa: E731
        if answer == "endless_line":
            return await _endless(request, "text/event-stream", b"x" * 65536, still)
        if answer == "endless_data":
            data = b"data: " + b"y" * 4090 + b"\n"
            return await _endless(request, "text/event-stream", data, still)
        if answer == "junk":
            junk = b": nothing to see\n\n"
            return await _endless(request, "text/event-stream", junk, still, pause_s=0.01)
        response = _sse_response()
        try:
            await response.prepare(request)
            if answer == "reset":
                await response.write(self._events()[: len(self._events()) // 2])
                _reset(request)
                return response
            while self.behaviour.events == "ok":
                if not self.behaviour.stall:
                    await response.write(self._events())
                await asyncio.sleep(0.02)
        except ConnectionResetError:
            pass  # the client went away
        return response

    def _events(self) -> bytes:
        stamp, values = self._values()
        return b"".join(
            b'event: update\ndata: {"node":%s,"timestamp":%d,"type":"double","value":%s}\n\n'
            % (orjson.dumps(n), stamp, v)
            for n, v in values.items()
        )


@asynccontextmanager
async def serving(device: FakeDevice) -> AsyncIterator[str]:
    """``device`` on a free loopback port; yields its base URL."""
    runner = web.AppRunner(device.app(), access_log=None, shutdown_timeout=1.0)
    await runner.setup()
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    try:
        yield f"http://127.0.0.1:{runner.addresses[0][1]}"
    finally:
        device.heal()  # release stalled handlers so shutdown does not wait for them
        await runner.cleanup()


def _problem(status: int, title: str, detail: str, instance: str | None = None) -> web.Response:
    body: dict[str, Any] = {"type": "about:blank", "title": title, "status": status}
    body["detail"] = detail
    if instance is not None:
        body["instance"] = instance
    return web.json_response(body, status=status)


def _sse_response() -> web.StreamResponse:
    return web.StreamResponse(headers={"Content-Type": "text/event-stream"})


async def _endless(
    request: web.Request,
    content_type: str,
    chunk: bytes,
    still: Callable[[], bool],
    pause_s: float = 0.0,
) -> web.StreamResponse:
    """Send ``chunk`` again and again until the client goes away or ``still()`` turns false.

    A device that behaves again ends its broken answers rather than repair them.
    """
    response = web.StreamResponse(headers={"Content-Type": content_type})
    try:
        await response.prepare(request)
        async with asyncio.timeout(STALL_S):
            while still():
                await response.write(chunk)
                await asyncio.sleep(pause_s)
    except (ConnectionResetError, TimeoutError):
        pass
    return response


def _reset(request: web.Request) -> None:
    """Drop the connection with a TCP reset, as a crashing device does."""
    transport = request.transport
    if transport is None:
        return
    sock = transport.get_extra_info("socket")
    if isinstance(sock, socket.socket):
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    transport.abort()
