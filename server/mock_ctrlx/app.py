"""The mock ctrlX REST API as an aiohttp application (identity manager + data layer).

Paths follow the published OpenAPI descriptions (identity manager v2.10.0,
data layer v2.1.5); the older firmware's ``/identity-manager/api/v1.0`` (and
``v1``) token and ``/automation/api/v1/<path>`` reads are served too. Admin
endpoints for fault injection live under ``/mock/``.
"""

from __future__ import annotations

import logging
import ssl
from typing import Any

from aiohttp import web
from aiohttp.typedefs import Handler

from ..ctrlx.paths import encode_node_path
from ..ctrlx.timestamps import filetime_from_unix
from . import events
from .auth import TokenIssuer
from .faults import Faults, faults_middleware
from .machine import Machine
from .nodes import NodeError, NodeTree
from .state import DL_BASE, STATE_KEY, MockState, bearer_token, problem, problem_body

log = logging.getLogger(__name__)

AUTH_BASES = ("/identity-manager/api/v2", "/identity-manager/api/v1.0", "/identity-manager/api/v1")
DL_V1_BASES = ("/automation/api/v1", "/automation/api/v1.0")
DEFAULT_USERS = {"boschrexroth": "boschrexroth"}


@web.middleware
async def count_traffic(request: web.Request, handler: Handler) -> web.StreamResponse:
    """Count ctrlX requests and response bodies (for benchmarks; streams count themselves)."""
    if not request.path.startswith(("/automation/", "/identity-manager/")):
        return await handler(request)
    traffic = request.app[STATE_KEY].traffic
    traffic.requests += 1
    response = await handler(request)
    if isinstance(response, web.Response) and isinstance(response.body, bytes):
        traffic.bytes_out += len(response.body)
    return response


@web.middleware
async def require_token(request: web.Request, handler: Handler) -> web.StreamResponse:
    """401 Problem for data-layer requests without a valid bearer token."""
    if request.path.startswith("/automation/"):
        token = bearer_token(request)
        reason = (
            "no bearer token given" if token is None else request.app[STATE_KEY].tokens.check(token)
        )
        if reason is not None:
            return problem(401, "Unauthorized", reason, request.path)
    return await handler(request)


# -- identity manager ---------------------------------------------------------


async def create_token(request: web.Request) -> web.Response:
    """POST /auth/token: 201 with a bearer token, 401 Problem on wrong credentials."""
    try:
        body = await request.json()
        user, password = body["name"], body["password"]
        if not isinstance(user, str) or not isinstance(password, str):
            raise TypeError
    except (ValueError, KeyError, TypeError):
        return problem(400, "Bad Request", "expected JSON with 'name' and 'password'")
    token = request.app[STATE_KEY].tokens.issue(user, password)
    if token is None:
        return problem(401, "Unauthorized", "wrong user name or password", request.path)
    if request.query.get("dryrun") == "true":
        return web.Response(status=204)
    return web.json_response({"access_token": token, "token_type": "Bearer"}, status=201)


async def delete_token(request: web.Request) -> web.Response:
    """DELETE /auth/token: revoke the bearer token (204 whatever it was)."""
    token = bearer_token(request)
    if token is not None:
        request.app[STATE_KEY].tokens.revoke(token)
    return web.Response(status=204)


async def token_validity(request: web.Request) -> web.Response:
    """GET /auth/token/validity: whether the bearer token is still accepted."""
    token = bearer_token(request)
    valid = token is not None and request.app[STATE_KEY].tokens.check(token) is None
    return web.json_response({"valid": valid})


# -- data layer ---------------------------------------------------------------


def _node_problem(request: web.Request, err: NodeError) -> web.Response:
    return problem(err.status, err.title, err.detail, request.path)


async def read_node(request: web.Request) -> web.Response:
    """GET /nodes/{path}[?type=browse|metadata]: value, children or metadata of a node."""
    state = request.app[STATE_KEY]
    node = request.match_info.get("path", "")  # percent-decoded by the router; "" is the root
    kind = request.query.get("type", "read")
    try:
        if kind == "browse":
            return web.json_response({"type": "arstring", "value": state.nodes.browse(node)})
        if kind == "metadata":
            return web.json_response({"type": "object", "value": state.nodes.metadata(node)})
        if kind not in ("read", "data"):
            return problem(400, "DL_INVALID_VALUE", f"unknown type '{kind}'", request.path)
        return web.json_response(state.nodes.read(node))
    except NodeError as err:
        return _node_problem(request, err)


async def write_node(request: web.Request) -> web.Response:
    """PUT /nodes/{path}: write a value, or command a move on a ``cmd`` node."""
    state = request.app[STATE_KEY]
    try:
        body = await request.json()
    except ValueError:
        return problem(400, "DL_TYPE_MISMATCH", "body is not JSON", request.path)
    try:
        return web.json_response(state.nodes.write(request.match_info["path"], body))
    except NodeError as err:
        return _node_problem(request, err)


async def bulk(request: web.Request) -> web.Response:
    """PUT /bulk?type=read|write|browse|metadata: many nodes in one round trip."""
    state = request.app[STATE_KEY]
    kind = request.query.get("type", "read")
    if kind not in ("read", "write", "browse", "metadata"):
        return problem(400, "DL_INVALID_VALUE", f"unsupported bulk type '{kind}'", request.path)
    try:
        items = await request.json()
        if not isinstance(items, list) or not all(
            isinstance(i, dict) and isinstance(i.get("address"), str) for i in items
        ):
            raise TypeError
    except (ValueError, TypeError):
        return problem(400, "DL_INVALID_VALUE", "expected [{'address': ...}, ...]", request.path)
    t = state.machine.now()
    positions = state.machine.snapshot(t)  # one instant for every node of the request
    stamp = str(filetime_from_unix(t))
    answer: list[dict[str, Any]] = []
    for item in items:
        node = item["address"]
        try:
            data = _bulk_one(state, kind, node, item, positions, t)
            entry = {"result": "DL_OK", "type": data["type"], "value": data["value"]}
        except NodeError as err:
            instance = f"{DL_BASE}/nodes/{encode_node_path(node)}"
            body = problem_body(err.status, err.title, err.detail, instance)
            entry = {"result": err.title, "type": "error", "value": body}
        answer.append({"address": node, "timestamp": stamp, **entry})
    return web.json_response(answer)


def _bulk_one(
    state: MockState,
    kind: str,
    node: str,
    item: dict[str, Any],
    positions: dict[str, float],
    t: float,
) -> dict[str, Any]:
    if kind == "read":
        return state.nodes.read(node, positions)
    if kind == "write":
        return state.nodes.write(node, item, t)
    if kind == "browse":
        return {"type": "arstring", "value": state.nodes.browse(node)}
    return {"type": "object", "value": state.nodes.metadata(node)}


# -- admin (not part of ctrlX) ------------------------------------------------


async def get_faults(request: web.Request) -> web.Response:
    """GET /mock/faults: the faults switched on now."""
    return web.json_response(request.app[STATE_KEY].faults.as_dict())


async def put_faults(request: web.Request) -> web.Response:
    """PUT /mock/faults: switch faults, e.g. ``{"outage": true}``."""
    faults = request.app[STATE_KEY].faults
    try:
        changes = await request.json()
        faults.update(changes if isinstance(changes, dict) else {})
    except (ValueError, TypeError):
        return problem(400, "Bad Request", "expected a JSON object of faults")
    return web.json_response(faults.as_dict())


async def get_stats(request: web.Request) -> web.Response:
    """GET /mock/stats: requests and body bytes served on the ctrlX paths, open streams."""
    state = request.app[STATE_KEY]
    return web.json_response(
        {
            "requests": state.traffic.requests,
            "bytes_out": state.traffic.bytes_out,
            "open_streams": state.open_streams,
        }
    )


async def drop_streams(request: web.Request) -> web.Response:
    """POST /mock/faults/drop-streams: end every open event stream."""
    request.app[STATE_KEY].faults.drop_streams()
    return web.Response(status=204)


async def revoke_all(request: web.Request) -> web.Response:
    """POST /mock/tokens/revoke-all: invalidate every token (clients must log in again)."""
    request.app[STATE_KEY].tokens.revoke_all()
    return web.Response(status=204)


async def _stop_streams(app: web.Application) -> None:
    app[STATE_KEY].closing = True


def build_app(
    machine: Machine | None = None,
    *,
    token_lifetime_s: float = 3600.0,
    users: dict[str, str] | None = None,
    subscriptions: bool = True,
    bulk_reads: bool = True,
    changes_only: bool = False,
) -> web.Application:
    """The mock app; run it with ``serve()``.

    ``subscriptions=False`` / ``bulk_reads=False`` leave those routes out, as on
    firmware without them (the client must fall back).
    """
    app = web.Application(
        middlewares=[
            count_traffic,
            faults_middleware(lambda a: a[STATE_KEY].faults),
            require_token,
        ]
    )
    machine = machine or Machine()
    app[STATE_KEY] = MockState(
        machine=machine,
        tokens=TokenIssuer(users=dict(users or DEFAULT_USERS), lifetime_s=token_lifetime_s),
        nodes=NodeTree(machine),
        faults=Faults(),
        changes_only=changes_only,
    )
    router = app.router
    for base in AUTH_BASES:
        router.add_post(base + "/auth/token", create_token)
        router.add_delete(base + "/auth/token", delete_token)
        router.add_get(base + "/auth/token/validity", token_validity)
    if bulk_reads:
        router.add_put(DL_BASE + "/bulk", bulk)
    if subscriptions:
        router.add_post(DL_BASE + "/events", events.create_subscription)
        router.add_get(DL_BASE + "/events", events.short_form)
        router.add_get(DL_BASE + "/events/{id}", events.open_subscription)
        router.add_delete(DL_BASE + "/events/{id}", events.delete_subscription)
    router.add_get(DL_BASE + "/nodes/", read_node)  # the root: browse lists the top nodes
    for base in (DL_BASE + "/nodes", *DL_V1_BASES):
        router.add_get(base + "/{path:.+}", read_node)
        router.add_put(base + "/{path:.+}", write_node)
    router.add_get("/mock/faults", get_faults)
    router.add_put("/mock/faults", put_faults)
    router.add_post("/mock/faults/drop-streams", drop_streams)
    router.add_get("/mock/stats", get_stats)
    router.add_post("/mock/tokens/revoke-all", revoke_all)
    app.on_shutdown.append(_stop_streams)
    return app


async def serve(
    app: web.Application, host: str, port: int, ssl_context: ssl.SSLContext | None = None
) -> tuple[web.AppRunner, str]:
    """Start ``app`` on host:port (0 picks a free port); returns the runner and base URL."""
    runner = web.AppRunner(app, access_log=None, shutdown_timeout=2.0)
    await runner.setup()
    site = web.TCPSite(runner, host, port, ssl_context=ssl_context)
    await site.start()
    bound = runner.addresses[0][1]
    scheme = "https" if ssl_context is not None else "http"
    return runner, f"{scheme}://{host}:{bound}"
