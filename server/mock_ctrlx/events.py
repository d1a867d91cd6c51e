"""Mock subscriptions: ``POST/GET/DELETE /events[/{id}]`` and their server-sent event streams.

A stream samples its nodes once per publish interval and sends one ``update``
event per node (all with the same FILETIME timestamp), an ``error`` event for
a node that cannot be read (at most once per error interval), and a
``keepalive`` when nothing was sent for a keepalive interval. It ends when its
token expires or is revoked, on ``drop_streams``, in an outage and on shutdown.
"""

from __future__ import annotations

import asyncio
import math
from typing import Any
from urllib.parse import quote

import orjson
from aiohttp import web

from ..ctrlx.pacing import Pacer
from ..ctrlx.paths import encode_node_path
from ..ctrlx.timestamps import filetime_from_unix
from .nodes import NodeError
from .state import (
    DL_BASE,
    STATE_KEY,
    MockState,
    SubscriptionSpec,
    bearer_token,
    problem,
    problem_body,
)

MIN_PUBLISH_MS = 5
"""Faster publishing would only burn the CPU the tests share with the server under test."""


def _interval(raw: Any, default: int) -> int:
    if isinstance(raw, bool) or not isinstance(raw, int) or raw < 0:
        return default
    return raw


async def create_subscription(request: web.Request) -> web.Response:
    """POST /events: create (or replace) a subscription; 201 with its Location."""
    try:
        body = await request.json()
        props, nodes = body["properties"], body["nodes"]
        sub_id = props["id"]
        if not (isinstance(sub_id, str) and sub_id and isinstance(nodes, list)):
            raise TypeError
        if not all(isinstance(n, str) for n in nodes):
            raise TypeError
    except (ValueError, KeyError, TypeError):
        return problem(
            400, "DL_INVALID_VALUE", "expected {'properties': {'id': ...}, 'nodes': [...]}"
        )
    request.app[STATE_KEY].subscriptions[sub_id] = SubscriptionSpec(
        id=sub_id,
        nodes=[n.strip("/") for n in nodes],
        publish_ms=_interval(props.get("publishInterval"), 1000),
        keepalive_ms=_interval(props.get("keepaliveInterval"), 60000),
        error_ms=_interval(props.get("errorInterval"), 10000),
    )
    location = f"{DL_BASE}/events/{quote(sub_id, safe='')}"
    return web.Response(status=201, headers={"Location": location})


async def open_subscription(request: web.Request) -> web.StreamResponse:
    """GET /events/{id}: the event stream of a created subscription."""
    sub_id = request.match_info["id"]
    spec = request.app[STATE_KEY].subscriptions.get(sub_id)
    if spec is None:
        return problem(404, "DL_INVALID_ADDRESS", f"no subscription '{sub_id}'", request.path)
    return await stream(request, spec)


async def short_form(request: web.Request) -> web.StreamResponse:
    """GET /events?nodes=a,b&publishIntervalMs=N: subscribe and stream in one request."""
    nodes = [n.strip("/") for n in request.query.get("nodes", "").split(",") if n.strip("/")]
    if not nodes:
        return problem(400, "DL_INVALID_VALUE", "query parameter 'nodes' is required")
    try:
        publish_ms = int(request.query.get("publishIntervalMs", "1000"))
    except ValueError:
        return problem(400, "DL_INVALID_VALUE", "publishIntervalMs must be an integer")
    return await stream(request, SubscriptionSpec(id="", nodes=nodes, publish_ms=publish_ms))


async def delete_subscription(request: web.Request) -> web.Response:
    """DELETE /events/{id}."""
    sub_id = request.match_info["id"]
    if request.app[STATE_KEY].subscriptions.pop(sub_id, None) is None:
        return problem(404, "DL_INVALID_ADDRESS", f"no subscription '{sub_id}'", request.path)
    return web.Response(status=200)


def sse(event: str, event_id: int, data: dict[str, Any]) -> bytes:
    """One server-sent event."""
    return b"event: %s\nid: %d\ndata: %s\n\n" % (event.encode(), event_id, orjson.dumps(data))


class _Publisher:
    """Builds the events of one publish cycle for one stream."""

    def __init__(self, state: MockState, spec: SubscriptionSpec) -> None:
        self._state = state
        self._spec = spec
        self._last_values: dict[str, Any] = {}
        self._last_error: dict[str, float] = {}
        self.event_id = 0

    def _next_id(self) -> int:
        self.event_id += 1
        return self.event_id

    def cycle(self, now: float) -> bytes:
        """Events for every node that has something to say at ``now`` (loop time)."""
        machine = self._state.machine
        t = machine.now()
        positions = machine.snapshot(t)
        stamp = filetime_from_unix(t)
        parts: list[bytes] = []
        for node in self._spec.nodes:
            try:
                data = self._state.nodes.read(node, positions)
            except NodeError as err:
                if now - self._last_error.get(node, -math.inf) >= self._spec.error_ms / 1000:
                    self._last_error[node] = now
                    instance = f"{DL_BASE}/nodes/{encode_node_path(node)}"
                    body = problem_body(err.status, err.title, err.detail, instance)
                    parts.append(sse("error", self._next_id(), {**body, "node": node}))
                continue
            value = data["value"]
            if self._state.changes_only and self._last_values.get(node) == value:
                continue
            self._last_values[node] = value
            update = {"event": "update", "node": node, "timestamp": stamp, **data}
            parts.append(sse("update", self._next_id(), update))
        return b"".join(parts)

    def keepalive(self) -> bytes:
        """A keepalive event stamped now."""
        stamp = filetime_from_unix(self._state.machine.now())
        data = {"event": "keepalive", "node": "", "timestamp": stamp, "value": ""}
        return sse("keepalive", self._next_id(), data)


async def stream(request: web.Request, spec: SubscriptionSpec) -> web.StreamResponse:
    """Serve ``spec`` as ``text/event-stream`` until something ends it."""
    state = request.app[STATE_KEY]
    faults, token = state.faults, bearer_token(request) or ""
    response = web.StreamResponse(
        headers={"Content-Type": "text/event-stream", "Cache-Control": "no-cache"}
    )
    await response.prepare(request)
    loop = asyncio.get_running_loop()
    publisher = _Publisher(state, spec)
    publish_s = max(spec.publish_ms, MIN_PUBLISH_MS) / 1000
    keepalive_s = max(spec.keepalive_ms, MIN_PUBLISH_MS) / 1000
    drops, last_write, pacer = faults.drops, loop.time(), Pacer(publish_s)
    state.open_streams += 1
    try:
        while not state.closing and faults.drops == drops:
            if faults.outage:
                if request.transport is not None:
                    request.transport.abort()
                return response
            if state.tokens.check(token) is not None:
                break  # the token expired or was revoked: the session is over
            now = loop.time()
            if not faults.stall_streams:
                chunk = publisher.cycle(now)
                if not chunk and now - last_write >= keepalive_s:
                    chunk = publisher.keepalive()
                if chunk:
                    state.traffic.bytes_out += len(chunk)
                    await response.write(chunk)
                    last_write = now
            await pacer.wait()
        await response.write_eof()
    except ConnectionResetError:
        pass  # the client went away
    finally:
        state.open_streams -= 1
    return response
