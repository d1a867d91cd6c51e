"""The mock ctrlX REST API as an aiohttp application (identity manager + data layer)."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any
from urllib.parse import unquote

from aiohttp import web
from aiohttp.typedefs import Handler

from .auth import TokenIssuer
from .machine import Machine

log = logging.getLogger(__name__)

AUTH_BASE = "/identity-manager/api/v2"
DL_BASE = "/automation/api/v2"
AXES_PREFIX = "motion/axs/"
DEFAULT_USERS = {"boschrexroth": "boschrexroth"}


@dataclass
class MockState:
    """Everything the mock handlers share."""

    machine: Machine
    tokens: TokenIssuer


STATE_KEY = web.AppKey("state", MockState)


def problem(status: int, title: str, detail: str, instance: str | None = None) -> web.Response:
    """An RFC 7807 Problem response, shaped as in the ctrlX OpenAPI descriptions."""
    body: dict[str, Any] = {
        "type": "about:blank",
        "title": title,
        "status": status,
        "detail": detail,
    }
    if instance is not None:
        body["instance"] = instance
    return web.json_response(body, status=status, content_type="application/problem+json")


def _bearer(request: web.Request) -> str | None:
    header = request.headers.get("Authorization", "")
    return header[7:] if header.startswith("Bearer ") else None


@web.middleware
async def require_token(request: web.Request, handler: Handler) -> web.StreamResponse:
    """401 Problem for data-layer requests without a valid bearer token."""
    if request.path.startswith(DL_BASE):
        token = _bearer(request)
        reason = (
            "no bearer token given"
            if token is None
            else (request.app[STATE_KEY].tokens.check(token))
        )
        if reason is not None:
            return problem(401, "Unauthorized", reason, request.path)
    return await handler(request)


async def create_token(request: web.Request) -> web.Response:
    """POST /auth/token: 201 with a bearer token, 401 Problem on wrong credentials."""
    try:
        body = await request.json()
        user, password = str(body["name"]), str(body["password"])
    except (ValueError, KeyError, TypeError):
        return problem(400, "Bad Request", "expected JSON with 'name' and 'password'")
    token = request.app[STATE_KEY].tokens.issue(user, password)
    if token is None:
        return problem(401, "Unauthorized", "wrong user name or password")
    return web.json_response({"access_token": token, "token_type": "Bearer"}, status=201)


def _axis_value(machine: Machine, node: str) -> dict[str, Any] | None:
    """The Data body of an axis node, or None when no such node exists."""
    if not node.startswith(AXES_PREFIX):
        return None
    axis, _, rest = node[len(AXES_PREFIX) :].partition("/")
    if axis not in machine.axes:
        return None
    sim = machine.axes[axis]
    if rest == "state/values/actual/pos":
        return {"type": "double", "value": machine.position(axis)}
    if rest == "state/values/actual":
        return {
            "type": "object",
            "value": {"actualPos": machine.position(axis), "actualPosUnit": sim.unit},
        }
    return None


async def read_node(request: web.Request) -> web.Response:
    """GET /nodes/{path}: a node's value, or 404 DL_INVALID_ADDRESS."""
    node = unquote(request.match_info["path"])
    data = _axis_value(request.app[STATE_KEY].machine, node)
    if data is None:
        return problem(404, "DL_INVALID_ADDRESS", f"node '{node}' does not exist", request.path)
    return web.json_response(data)


def build_app(
    machine: Machine | None = None,
    *,
    token_lifetime_s: float = 3600.0,
    users: dict[str, str] | None = None,
) -> web.Application:
    """The mock app; run it with ``aiohttp.web`` or ``serve()``."""
    app = web.Application(middlewares=[require_token])
    app[STATE_KEY] = MockState(
        machine=machine or Machine(),
        tokens=TokenIssuer(users=dict(users or DEFAULT_USERS), lifetime_s=token_lifetime_s),
    )
    app.router.add_post(AUTH_BASE + "/auth/token", create_token)
    app.router.add_get(DL_BASE + "/nodes/{path:.+}", read_node)
    return app


async def serve(app: web.Application, host: str, port: int) -> tuple[web.AppRunner, str]:
    """Start ``app`` on host:port (0 picks a free port); returns the runner and base URL."""
    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    site = web.TCPSite(runner, host, port)
    await site.start()
    bound = runner.addresses[0][1]
    return runner, f"http://{host}:{bound}"
