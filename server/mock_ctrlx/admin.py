"""The mock's admin endpoints (``/mock/...``: faults, stats, token revocation) and their guard.

They are no part of ctrlX and anyone who reaches them can break the mock,
so they answer only to loopback peers that name the mock by a loopback host,
and never to a browser page of another origin: a request whose ``Origin`` is
not the mock's own, or whose ``Sec-Fetch-Site`` is ``cross-site``, gets a 403
Problem. The host check keeps a DNS-rebinding page (whose Origin and Host
both name the attacker's domain) out as well.
"""

from __future__ import annotations

from aiohttp import web
from aiohttp.typedefs import Handler

from ..hosts import host_name, is_loopback
from .problems import request_problem
from .state import STATE_KEY

ADMIN_PREFIX = "/mock/"


def refusal(request: web.Request) -> str | None:
    """Why ``request`` may not use the admin endpoints, or None when it may."""
    if not is_loopback(request.remote):
        return "the admin endpoints answer only to loopback clients"
    if not is_loopback(host_name(request.host)):
        return "the admin endpoints answer only to a loopback host name"
    origin = request.headers.get("Origin")
    if origin is not None and origin != f"{request.scheme}://{request.host}":
        return "cross-origin requests to the admin endpoints are refused"
    if request.headers.get("Sec-Fetch-Site", "").lower() == "cross-site":
        return "cross-site requests to the admin endpoints are refused"
    return None


@web.middleware
async def guard_admin(request: web.Request, handler: Handler) -> web.StreamResponse:
    """403 Problem for an admin request from elsewhere than this machine or this origin."""
    if request.path.startswith(ADMIN_PREFIX) or request.path == ADMIN_PREFIX.rstrip("/"):
        reason = refusal(request)
        if reason is not None:
            return request_problem(request, 403, "Forbidden", reason)
    return await handler(request)


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
        return request_problem(request, 400, "Bad Request", "expected a JSON object of faults")
    return web.json_response(faults.as_dict())


async def get_stats(request: web.Request) -> web.Response:
    """GET /mock/stats: requests and body bytes on the ctrlX paths, streams, subscriptions."""
    state = request.app[STATE_KEY]
    return web.json_response(
        {
            "requests": state.traffic.requests,
            "bytes_out": state.traffic.bytes_out,
            "most_in_flight": state.traffic.most_in_flight,
            "open_streams": state.open_streams,
            "subscriptions": len(state.subscriptions),
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


def add_admin_routes(router: web.UrlDispatcher) -> None:
    """Route the admin endpoints."""
    router.add_get("/mock/faults", get_faults)
    router.add_put("/mock/faults", put_faults)
    router.add_post("/mock/faults/drop-streams", drop_streams)
    router.add_get("/mock/stats", get_stats)
    router.add_post("/mock/tokens/revoke-all", revoke_all)
