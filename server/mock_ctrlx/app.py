"""The mock ctrlX REST API as an aiohttp application (identity manager + data layer).

Paths follow the published OpenAPI descriptions (identity manager v2.10.0,
data layer v2.1.5); the older firmware's ``/identity-manager/api/v1.0`` (and
``v1``) token and ``/automation/api/v1/<path>`` nodes are served too. Every
collection route also takes a trailing slash, as the device does (Node-RED's
ctrlX nodes create subscriptions with ``POST /automation/api/v2/events/``).
Whatever is not served answers a Problem (``application/json``), never a
plain-text 404 or 405. Admin endpoints for fault injection live under
``/mock/`` (see ``admin``).
"""

from __future__ import annotations

import logging
import ssl
from collections.abc import Mapping

from aiohttp import web
from aiohttp.typedefs import Handler

from . import datalayer, events, identity
from .admin import add_admin_routes, guard_admin
from .auth import TokenIssuer
from .faults import Faults, faults_middleware
from .machine import Machine
from .nodes import NodeTree
from .problems import request_problem
from .state import DL_BASE, STATE_KEY, MockState, Subscriptions, bearer_token

log = logging.getLogger(__name__)

IM_BASE = "/identity-manager/api/v2"
AUTH_BASES = (IM_BASE, "/identity-manager/api/v1.0", "/identity-manager/api/v1")
DL_V1_BASES = ("/automation/api/v1", "/automation/api/v1.0")
DEFAULT_USERS = {"boschrexroth": "boschrexroth"}
DEFAULT_LAG_S = 0.008
"""How far the demo machine's actual positions trail their setpoints: a few cycles of a drive."""


@web.middleware
async def count_traffic(request: web.Request, handler: Handler) -> web.StreamResponse:
    """Count ctrlX requests and response bodies (for benchmarks; streams count themselves)."""
    if not request.path.startswith(("/automation/", "/identity-manager/")):
        return await handler(request)
    traffic = request.app[STATE_KEY].traffic
    traffic.requests += 1
    traffic.in_flight += 1
    traffic.most_in_flight = max(traffic.most_in_flight, traffic.in_flight)
    try:
        response = await handler(request)
    finally:
        traffic.in_flight -= 1
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
            title = "DL_SEC_NOTOKEN" if token is None else "DL_SEC_INVALIDSESSION"
            return request_problem(request, 401, "Unauthorized", reason, dynamic=title)
    return await handler(request)


@web.middleware
async def problems_only(request: web.Request, handler: Handler) -> web.StreamResponse:
    """Turn the router's plain-text errors (unknown path, wrong method) into Problems."""
    try:
        return await handler(request)
    except web.HTTPException as exc:
        if exc.status < 400:
            raise
        title = exc.reason or "Error"
        detail = f"{request.method} {request.path}: {title.lower()}"
        response = request_problem(request, exc.status, title, detail)
        if isinstance(exc, web.HTTPMethodNotAllowed):
            response.headers["Allow"] = ", ".join(sorted(exc.allowed_methods))
        return response


def _route(router: web.UrlDispatcher, path: str, handlers: Mapping[str, Handler]) -> None:
    """Route ``path``, with and without a trailing slash, for each method of ``handlers``."""
    for variant in (path, path + "/"):
        for method, handler in handlers.items():
            router.add_route(method, variant, handler)


def _identity_routes(router: web.UrlDispatcher) -> None:
    for base in AUTH_BASES:
        token = {
            "POST": identity.create_token,
            "GET": identity.get_token,
            "DELETE": identity.delete_token,
        }
        _route(router, base + "/auth/token", token)
        _route(router, base + "/auth/token/validity", {"GET": identity.token_validity})
    _route(router, IM_BASE + "/setup/state", {"GET": identity.setup_state})
    _route(router, IM_BASE + "/auth/oidc/login", {"GET": identity.oidc_login})
    _route(router, IM_BASE + "/auth/oidc/callback", {"GET": identity.oidc_callback})
    for template, methods in identity.UNSERVED.items():
        handlers = {m: identity.unserved(template, m) for m in methods.split()}
        _route(router, IM_BASE + template, handlers)


def _datalayer_routes(router: web.UrlDispatcher, *, subscriptions: bool, bulk: bool) -> None:
    if bulk:
        _route(router, DL_BASE + "/bulk", {"PUT": datalayer.bulk})
    if subscriptions:
        _route(
            router,
            DL_BASE + "/events",
            {"POST": events.create_subscription, "GET": events.short_form},
        )
        one = {
            "GET": events.open_subscription,
            "PUT": events.change_subscription,
            "DELETE": events.delete_subscription,
        }
        _route(router, DL_BASE + "/events/{id}", one)
    nodes: dict[str, Handler] = {
        "GET": datalayer.read_node,
        "PUT": datalayer.write_node,
        "POST": datalayer.create_node,
        "DELETE": datalayer.delete_node,
    }
    for base in (DL_BASE + "/nodes", *DL_V1_BASES):
        _route(router, base, nodes)  # the root, "/nodes" or "/nodes/"
        for method, handler in nodes.items():
            # "{path:.+}" takes a trailing slash along; the handlers strip it.
            router.add_route(method, base + "/{path:.+}", handler)


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
    subscription_lifetime_s: float = 60.0,
) -> web.Application:
    """The mock app; run it with ``serve()``.

    ``subscriptions=False`` / ``bulk_reads=False`` leave those routes out, as on
    firmware without them (they answer 404, and the client must fall back).
    ``subscription_lifetime_s``: how long a created subscription outlives its
    last open stream (the spec's minute by default).
    """
    app = web.Application(
        middlewares=[
            count_traffic,
            guard_admin,
            faults_middleware(lambda a: a[STATE_KEY].faults),
            require_token,
            problems_only,
        ]
    )
    machine = machine or Machine(lag_s=DEFAULT_LAG_S)
    app[STATE_KEY] = MockState(
        machine=machine,
        tokens=TokenIssuer(users=dict(users or DEFAULT_USERS), lifetime_s=token_lifetime_s),
        nodes=NodeTree(machine),
        faults=Faults(),
        subscriptions=Subscriptions(lifetime_s=subscription_lifetime_s),
        changes_only=changes_only,
    )
    _identity_routes(app.router)
    _datalayer_routes(app.router, subscriptions=subscriptions, bulk=bulk_reads)
    add_admin_routes(app.router)
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
