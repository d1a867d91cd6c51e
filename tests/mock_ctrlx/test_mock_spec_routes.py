"""Every operation of both ctrlX descriptions answers as described, and Problems are complete.

Each operation is sent to a running mock over a real socket: it either works,
or answers a Problem (``application/json``) with a status its description
lists; with a token and, where it needs one, without. Every answer is validated
with openapi-core against the vendored descriptions (with the errata of spec.py),
event streams (their first events) and ReadNode's 200 included.
"""

from __future__ import annotations

import asyncio
import json
import re
from collections.abc import AsyncIterator
from dataclasses import dataclass, field
from typing import Any

import aiohttp
import pytest
from openapi_core import OpenAPI
from openapi_core.testing import MockRequest, MockResponse

from tests.ctrlx.helpers import KIN12, Mock, running
from tests.mock_ctrlx.spec import (
    DL,
    DL_API,
    FIXED_DL,
    IM,
    IM_API,
    RAW_IM,
    component,
    parse_event_stream,
)

SUBSCRIPTION = "spec-sub"
HEX8 = re.compile(r"[0-9A-F]{8}")
PROBLEM_FIELDS = set(FIXED_DL["components"]["schemas"]["Problem"]["properties"]) | set(
    RAW_IM["components"]["schemas"]["Problem"]["properties"]
)


@dataclass
class Case:
    """How to call one operation, and what it must answer with a valid token."""

    path: str
    params: dict[str, str] = field(default_factory=dict)
    body: Any = None
    expect: int | None = None
    """The status; None: any status the description lists (a Problem when >= 400)."""
    stream: bool = False


def _fill(template: str) -> str:
    return re.sub(r"\{[^}]+\}", "x", template)


def data_layer_case(template: str, method: str) -> Case:
    """The data-layer request for one operation (``template`` relative to its base)."""
    node = {"GET": KIN12[0], "PUT": "plc/app/Application/sym/PLC_PRG/dTest"}
    if template == "/nodes/{Path}":
        if method == "POST":
            body = {"type": "object", "value": {"axsPos": [1.0, 2.0]}}
            return Case("/nodes/motion/grp/kin12/cmd/pos-abs", body=body, expect=200)
        if method == "DELETE":
            return Case("/nodes/" + KIN12[0], expect=403)
        body = {"type": "double", "value": 1.5} if method == "PUT" else None
        return Case("/nodes/" + node[method], body=body, expect=200)
    subscription = "/clients/{ClientName}/subscriptions/{SubscriptionName}"
    if subscription in template:
        path = template.replace("{ClientName}", "boschrexroth")
        return Case(path.replace("{SubscriptionName}", SUBSCRIPTION), expect=200)
    if template.startswith("/nodes/datalayer/retain/chunks"):
        body = {"type": "object", "value": {"id": "c", "sizeBytes": 8}}
        return Case(_fill(template), body=body if method == "POST" else None)
    if template.startswith("/nodes/datalayer/") and method in ("GET", "PUT"):
        body = None
        if method == "PUT":
            key = "serverIdlePingTimeout" if "server" in template else "minimumPublishInterval"
            body = {"type": "object", "value": {key: 40}}
        return Case(template, body=body, expect=200)
    if template.startswith("/nodes/"):
        return Case(_fill(template), body={"type": "string", "value": "x"}, expect=None)
    events = {
        ("/events", "GET"): Case("/events", {"nodes": KIN12[0]}, expect=200, stream=True),
        ("/events", "POST"): Case(
            "/events", body={"properties": {"id": "other"}, "nodes": KIN12}, expect=201
        ),
        ("/events/{SubscriptionName}", "GET"): Case(
            f"/events/{SUBSCRIPTION}", expect=200, stream=True
        ),
        ("/events/{SubscriptionName}", "PUT"): Case(
            f"/events/{SUBSCRIPTION}", body={"id": SUBSCRIPTION, "nodes": KIN12}, expect=200
        ),
        ("/events/{SubscriptionName}", "DELETE"): Case("/events/other", expect=200),
        ("/bulk", "PUT"): Case("/bulk", {"type": "read"}, [{"address": KIN12[0]}], 200),
    }
    return events[(template, method)]


def identity_case(template: str, method: str) -> Case:
    """The identity-manager request for one operation (``template`` relative to its base)."""
    known = {
        ("/auth/token", "POST"): Case(
            template, body={"name": "boschrexroth", "password": "boschrexroth"}, expect=201
        ),
        ("/auth/token", "GET"): Case(template, expect=401),  # no session cookie
        ("/auth/token", "DELETE"): Case(template, expect=204),
        ("/auth/token/validity", "GET"): Case(template, expect=200),
        ("/auth/oidc/login", "GET"): Case(template, {"provider-id": "p"}, expect=302),
        ("/auth/oidc/callback", "GET"): Case(template, {"code": "c"}, expect=400),
        ("/setup/state", "GET"): Case(template, expect=200),
    }
    return known.get((template, method)) or Case(_fill(template))


def operations(document: dict[str, Any]) -> list[tuple[str, str, dict[str, Any]]]:
    """(template, METHOD, operation) of every operation of ``document``."""
    return [
        (template, method.upper(), op)
        for template, item in document["paths"].items()
        for method, op in item.items()
        if method != "parameters"
    ]


async def call(
    http: aiohttp.ClientSession,
    mock: Mock,
    api: OpenAPI,
    base: str,
    template: str,
    method: str,
    case: Case,
    token: str | None,
) -> tuple[int, str, Any]:
    """Send one case; validate the answer with openapi-core; (status, content type, body)."""
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    data = json.dumps(case.body).encode() if case.body is not None else None
    if data is not None:
        headers["Content-Type"] = "application/json"
    async with http.request(
        method,
        mock.url + base + case.path,
        params=case.params,
        data=data,
        headers=headers,
        allow_redirects=False,
    ) as resp:
        status, content_type = resp.status, resp.content_type
        stream = status == 200 and content_type == "text/event-stream"
        raw = await first_events(resp) if stream else await resp.read()
        answer_headers = dict(resp.headers)
    request = MockRequest(
        mock.url, method.lower(), base + case.path, path_pattern=base + template,
        args=case.params, headers=headers, data=data,
        content_type="application/json" if data else "",
    )  # fmt: skip
    # Event streams too: their events are the description's SSE_Event items (spec.py).
    response = MockResponse(raw, status, content_type=content_type, headers=answer_headers)
    api.validate_response(request, response)
    body = json.loads(raw) if raw and content_type == "application/json" else None
    if stream:
        assert len(parse_event_stream(raw)) >= STREAM_EVENTS
    return status, content_type, body


STREAM_EVENTS = 3
"""Events read from each event stream (it never ends by itself) before it is validated."""


async def first_events(resp: aiohttp.ClientResponse) -> bytes:
    """The stream's bytes up to the end of its ``STREAM_EVENTS``-th event."""
    raw = b""
    async with asyncio.timeout(10):
        while raw.count(b"\n\n") < STREAM_EVENTS:
            raw += await resp.content.readany()
    return raw[: _nth(raw, b"\n\n", STREAM_EVENTS) + 2]


def _nth(text: bytes, part: bytes, n: int) -> int:
    at = -1
    for _ in range(n):
        at = text.index(part, at + 1)
    return at


@pytest.fixture
async def mock() -> AsyncIterator[Mock]:
    async with running() as running_mock:
        yield running_mock


async def login(http: aiohttp.ClientSession, mock: Mock) -> str:
    credentials = {"name": "boschrexroth", "password": "boschrexroth"}
    async with http.post(f"{mock.url}{IM}/auth/token", json=credentials) as resp:
        assert resp.status == 201
        return str((await resp.json())["access_token"])


def assert_problem(body: Any, status: int) -> None:
    """``body`` is a Problem with every field of the schema and 8-hex-digit diagnosis codes."""
    assert isinstance(body, dict) and PROBLEM_FIELDS <= set(body), PROBLEM_FIELDS - set(body)
    assert body["status"] == status and body["type"] == "about:blank" and body["title"]
    assert HEX8.fullmatch(body["mainDiagnosisCode"]), body["mainDiagnosisCode"]
    assert HEX8.fullmatch(body["detailedDiagnosisCode"]), body["detailedDiagnosisCode"]
    assert body["severity"] == "Error"
    component(FIXED_DL, "Problem").validate(body)


@pytest.mark.parametrize(
    ("document", "api", "base", "case_of"),
    [(FIXED_DL, DL_API, DL, data_layer_case), (RAW_IM, IM_API, IM, identity_case)],
    ids=["datalayer", "identitymanager"],
)
async def test_every_operation_answers_as_described(
    mock: Mock, document: dict[str, Any], api: OpenAPI, base: str, case_of: Any
) -> None:
    async with aiohttp.ClientSession() as http:
        token = await login(http, mock)
        body = {"properties": {"id": SUBSCRIPTION, "publishInterval": 50}, "nodes": KIN12}
        async with http.post(f"{mock.url}{DL}/events", json=body, headers={
            "Authorization": f"Bearer {token}"}) as resp:  # fmt: skip
            assert resp.status == 201
        checked = 0
        # The token's own DELETE goes last: it ends the session the others use.
        ops = sorted(operations(document), key=lambda o: o[:2] == ("/auth/token", "DELETE"))
        for template, method, op in ops:
            listed = {int(s) for s in op["responses"]}
            case = case_of(template, method)
            status, content_type, answer = await call(
                http, mock, api, base, template, method, case, token
            )
            where = f"{method} {template} -> {status}"
            assert status in listed, where
            assert case.expect is None or status == case.expect, where
            if status >= 400:
                assert content_type == "application/json", where
                assert_problem(answer, status)
            secured = op.get("security", document.get("security")) != []
            if secured and 401 in listed:
                status, _, answer = await call(http, mock, api, base, template, method, case, None)
                assert status == 401, f"{method} {template} without a token -> {status}"
                assert_problem(answer, 401)
            checked += 1
    assert checked == len(operations(document)) > 30


async def test_unknown_routes_and_methods_answer_problems(mock: Mock) -> None:
    async with aiohttp.ClientSession() as http:
        token = await login(http, mock)
        headers = {"Authorization": f"Bearer {token}"}
        for method, path, status in [
            ("GET", "/nope", 404),
            ("GET", "/automation/api/v2/nope", 404),
            ("PATCH", "/automation/api/v2/bulk", 405),
            ("GET", "/identity-manager/api/v2/nope", 404),
            ("PATCH", "/identity-manager/api/v2/auth/token", 405),
        ]:
            async with http.request(method, mock.url + path, headers=headers) as resp:
                assert resp.status == status and resp.content_type == "application/json"
                body = await resp.json()
            assert_problem(body, status)
            assert body["instance"] == path


async def test_node_problems_name_the_node_everywhere(mock: Mock) -> None:
    """HTTP answers, bulk entries and SSE error events all carry the node address."""
    nope = "motion/axs/nope/state/values/actual/pos"
    async with aiohttp.ClientSession() as http:
        headers = {"Authorization": f"Bearer {await login(http, mock)}"}
        for method in ("GET", "PUT", "POST", "DELETE"):
            async with http.request(method, f"{mock.url}{DL}/nodes/{nope}", headers=headers,
                                    json={"type": "double", "value": 1.0}) as resp:  # fmt: skip
                assert resp.status == 404
                body = await resp.json()
            assert_problem(body, 404)
            assert body["instance"] == nope and body["title"] == "DL_INVALID_ADDRESS"
            assert body["detailedDiagnosisCode"] == "80010001"
        async with http.put(f"{mock.url}{DL}/bulk", params={"type": "read"}, headers=headers,
                            json=[{"address": nope}]) as resp:  # fmt: skip
            (entry,) = await resp.json()
        assert entry["result"] == "DL_INVALID_ADDRESS" and entry["type"] == "error"
        assert_problem(entry["value"], 404)
        assert entry["value"]["instance"] == nope
