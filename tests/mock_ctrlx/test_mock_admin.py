"""The admin endpoints answer loopback clients of their own origin only (403 Problem otherwise)."""

from __future__ import annotations

from typing import Any
from unittest.mock import MagicMock

import aiohttp
import pytest
from aiohttp import web
from aiohttp.test_utils import make_mocked_request

from server.mock_ctrlx.admin import guard_admin
from tests.ctrlx.helpers import running


@pytest.mark.parametrize(
    ("headers", "allowed"),
    [
        ({}, True),
        ({"Origin": "OWN"}, True),
        ({"Sec-Fetch-Site": "same-origin"}, True),
        ({"Sec-Fetch-Site": "none"}, True),  # typed into the address bar
        ({"Origin": "http://evil.example"}, False),
        ({"Origin": "null"}, False),  # a sandboxed frame or a file:// page
        ({"Origin": "http://localhost:1"}, False),  # another local page
        ({"Sec-Fetch-Site": "cross-site"}, False),
        ({"Host": "evil.example"}, False),  # DNS rebinding: the page's own host name
        ({"Host": "evil.example", "Origin": "http://evil.example"}, False),
    ],
)
async def test_admin_requests_from_other_origins_are_refused(
    headers: dict[str, str], allowed: bool
) -> None:
    async with running() as mock, aiohttp.ClientSession() as http:
        sent = {k: mock.url if v == "OWN" else v for k, v in headers.items()}
        async with http.put(f"{mock.url}/mock/faults", json={"latency_s": 0.5},
                            headers=sent) as resp:  # fmt: skip
            status, content_type, body = resp.status, resp.content_type, await resp.json()
        async with http.post(f"{mock.url}/mock/tokens/revoke-all", headers=sent) as resp:
            revoke_status = resp.status
    if allowed:
        assert (status, revoke_status) == (200, 204)
        assert mock.state.faults.latency_s == 0.5
    else:
        assert (status, revoke_status) == (403, 403)
        assert content_type == "application/json" and body["status"] == 403
        assert body["instance"] == "/mock/faults" and body["detail"]
        assert mock.state.faults.latency_s == 0.0  # nothing was switched
        assert mock.state.tokens.issued == 0


def _request_from(peer: tuple[Any, ...], host: str = "127.0.0.1:8443") -> web.Request:
    transport = MagicMock()
    transport.get_extra_info.side_effect = lambda name, default=None: (
        peer if name == "peername" else default
    )
    return make_mocked_request("GET", "/mock/stats", headers={"Host": host}, transport=transport)


@pytest.mark.parametrize(
    ("peer", "allowed"),
    [
        (("127.0.0.1", 5000), True),
        (("127.0.0.2", 5000), True),
        (("::1", 5000, 0, 0), True),
        (("192.0.2.7", 5000), False),  # documentation range: never contacted
        (("2001:db8::7", 5000, 0, 0), False),
    ],
)
async def test_admin_answers_loopback_peers_only(peer: tuple[Any, ...], allowed: bool) -> None:
    """No socket can come from another machine here, so the peer address is simulated."""

    async def handler(request: web.Request) -> web.StreamResponse:
        return web.Response(text="admin")

    response = await guard_admin(_request_from(peer), handler)
    assert isinstance(response, web.Response)
    assert response.status == (200 if allowed else 403)
    assert (response.text == "admin") is allowed


async def test_ctrlx_paths_are_not_guarded() -> None:
    """The guard keeps /mock only; the ctrlX paths answer as before, whatever the Origin."""
    async with running() as mock, aiohttp.ClientSession() as http:
        credentials = {"name": "boschrexroth", "password": "boschrexroth"}
        async with http.post(f"{mock.url}/identity-manager/api/v2/auth/token", json=credentials,
                             headers={"Origin": "http://evil.example"}) as resp:  # fmt: skip
            assert resp.status == 201
