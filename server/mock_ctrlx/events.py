"""Mock subscriptions: ``POST/GET/PUT/DELETE /events[/{id}]`` and their server-sent event streams.

A stream samples its nodes once per publish interval and sends one ``update``
event per node (all with the same FILETIME timestamp), an ``error`` event for
a node that cannot be read (at most once per error interval; a Problem whose
``instance`` is the node address), and a ``keepalive`` when nothing was sent
for a keepalive interval. It ends when its token expires or is revoked, on
``drop_streams``, in an outage and on shutdown.

A created subscription lives while a stream of it is open and for its
lifetime (60 s by default, as the spec says) after the last one closed;
deleting it while a stream is open answers 409.
"""

from __future__ import annotations

import asyncio
import math
from typing import Any
from urllib.parse import quote

import orjson
from aiohttp import web

from ..ctrlx.pacing import Pacer
from ..ctrlx.timestamps import filetime_from_unix
from .datalayer import BadBody, json_body, read
from .nodes import MIN_PUBLISH_MS, NodeError, Snapshot
from .problems import problem_body, request_problem
from .state import DL_BASE, STATE_KEY, MockState, SubscriptionSpec, bearer_token

UINT32_MAX = 4294967295
HANGUP_GRACE_S = 0.05
"""How long DELETE waits for a stream whose client just hung up to notice it."""
HANGUP_POLL_S = 0.05
"""How often a stream waiting for its next publish looks whether its client hung up."""


def _interval(props: dict[str, Any], name: str, default: int) -> int:
    """A uint32 property; numbers sent as strings (``"200"``) count, as the device takes them."""
    raw = props.get(name)
    if raw is None:
        return default
    value: float
    if isinstance(raw, bool):
        raise BadBody(f"{name} must be a number, not {raw!r}")
    if isinstance(raw, str):
        try:
            value = float(raw.strip())
        except ValueError:
            raise BadBody(f"{name} must be a number, not {raw!r}") from None
    elif isinstance(raw, int | float):
        value = raw
    else:
        raise BadBody(f"{name} must be a number, not {raw!r}")
    if not (math.isfinite(value) and 0 <= value <= UINT32_MAX):
        raise BadBody(f"{name} must be between 0 and {UINT32_MAX}, not {raw!r}")
    return round(value)


def _nodes(raw: Any) -> list[str]:
    if not isinstance(raw, list) or not all(isinstance(n, str) for n in raw):
        raise BadBody("'nodes' must be a list of node addresses")
    return [n.strip("/") for n in raw]


def _spec(body: Any) -> SubscriptionSpec:
    """The subscription a ``POST /events`` body asks for."""
    if not isinstance(body, dict) or not isinstance(body.get("properties"), dict):
        raise BadBody("expected {'properties': {'id': ...}, 'nodes': [...]}")
    props = body["properties"]
    sub_id = props.get("id")
    if not isinstance(sub_id, str) or not sub_id:
        raise BadBody("properties.id must be a non-empty string")
    rules = props.get("rules", [])
    if not isinstance(rules, list):
        raise BadBody("properties.rules must be a list")
    return SubscriptionSpec(
        id=sub_id,
        nodes=_nodes(body.get("nodes")),
        publish_ms=_interval(props, "publishInterval", 1000),
        keepalive_ms=_interval(props, "keepaliveInterval", 60000),
        error_ms=_interval(props, "errorInterval", 10000),
        rules=rules,
    )


async def create_subscription(request: web.Request) -> web.Response:
    """POST /events: create (or update) a subscription; 201 with its Location."""
    try:
        spec = _spec(await json_body(request))
    except BadBody as exc:
        return request_problem(request, 400, "DL_INVALID_VALUE", str(exc))
    request.app[STATE_KEY].subscriptions.put(spec)
    location = f"{DL_BASE}/events/{quote(spec.id, safe='')}"
    return web.Response(status=201, headers={"Location": location})


async def change_subscription(request: web.Request) -> web.Response:
    """PUT /events/{id} with ``{"id", "nodes"}``: a new node list, open streams included."""
    sub_id = request.match_info["id"]
    spec = request.app[STATE_KEY].subscriptions.get(sub_id)
    if spec is None:
        return request_problem(request, 404, "DL_INVALID_ADDRESS", f"no subscription '{sub_id}'")
    try:
        body = await json_body(request)
        if not isinstance(body, dict):
            raise BadBody("expected {'id': ..., 'nodes': [...]}")
        nodes = _nodes(body.get("nodes"))
    except BadBody as exc:
        return request_problem(request, 400, "DL_INVALID_VALUE", str(exc))
    spec.nodes = nodes
    return web.Response(status=200)


async def open_subscription(request: web.Request) -> web.StreamResponse:
    """GET /events/{id}: the event stream of a created subscription."""
    sub_id = request.match_info["id"]
    spec = request.app[STATE_KEY].subscriptions.get(sub_id)
    if spec is None:
        return request_problem(request, 404, "DL_INVALID_ADDRESS", f"no subscription '{sub_id}'")
    return await stream(request, spec, created=True)


async def short_form(request: web.Request) -> web.StreamResponse:
    """GET /events?nodes=a,b&publishIntervalMs=N: subscribe and stream in one request."""
    nodes = [n.strip("/") for n in request.query.get("nodes", "").split(",") if n.strip("/")]
    if not nodes:
        return request_problem(request, 400, "DL_INVALID_VALUE", "query 'nodes' is required")
    try:
        publish_ms = _interval(dict(request.query), "publishIntervalMs", 1000)
    except BadBody as exc:
        return request_problem(request, 400, "DL_INVALID_VALUE", str(exc))
    spec = SubscriptionSpec(id="", nodes=nodes, publish_ms=publish_ms)
    return await stream(request, spec, created=False)


async def delete_subscription(request: web.Request) -> web.Response:
    """DELETE /events/{id}: 200, or 409 while a stream of it is open."""
    subscriptions = request.app[STATE_KEY].subscriptions
    sub_id = request.match_info["id"]
    spec = subscriptions.get(sub_id)
    if spec is None:
        return request_problem(request, 404, "DL_INVALID_ADDRESS", f"no subscription '{sub_id}'")
    if spec.live_streams():
        # A client that closes its stream and deletes at once races its own hang-up.
        await asyncio.sleep(HANGUP_GRACE_S)
    if spec.live_streams():
        detail = f"subscription '{sub_id}' has an open event stream"
        return request_problem(request, 409, "DL_RESOURCE_UNAVAILABLE", detail)
    subscriptions.pop(sub_id)
    return web.Response(status=200)


def _hung_up(request: web.Request) -> bool:
    return request.transport is None or request.transport.is_closing()


async def _next_tick(pacer: Pacer, request: web.Request) -> bool:
    """Wait for the pacer's next tick; False as soon as the client hangs up.

    A stream otherwise notices a gone client only when its next write fails,
    a whole publish interval later; its subscription's lifetime starts when
    its last stream ends, so the end should be seen at once.
    """
    if _hung_up(request):
        return False
    if pacer.due_in() <= HANGUP_POLL_S:  # one sleep, as one round of the poll: no task for it
        await pacer.wait()
        return not _hung_up(request)
    tick = asyncio.ensure_future(pacer.wait())
    try:
        while not tick.done():
            if _hung_up(request):
                return False
            await asyncio.wait([tick], timeout=HANGUP_POLL_S)
    finally:
        tick.cancel()
    return not _hung_up(request)


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
        snapshot = Snapshot(machine, t)
        stamp = filetime_from_unix(t)
        parts: list[bytes] = []
        for node in list(self._spec.nodes):  # a PUT may change the list between cycles
            try:
                data = read(self._state, node, snapshot)
            except NodeError as err:
                if now - self._last_error.get(node, -math.inf) >= self._spec.error_ms / 1000:
                    self._last_error[node] = now
                    body = problem_body(err.status, err.title, err.detail, node, dynamic=node)
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


async def stream(
    request: web.Request, spec: SubscriptionSpec, *, created: bool
) -> web.StreamResponse:
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
    if created:
        state.subscriptions.opened(spec, request)
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
            if not await _next_tick(pacer, request):
                return response  # the client hung up
        await response.write_eof()
    except ConnectionResetError:
        pass  # the client went away
    finally:
        state.open_streams -= 1
        if created:
            state.subscriptions.closed(spec, request)
    return response
