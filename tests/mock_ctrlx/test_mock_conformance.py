"""The mock answers as the published ctrlX OpenAPI descriptions say (validated with openapi-core).

The descriptions and their errata are loaded by ``tests.mock_ctrlx.spec``.
"""

from __future__ import annotations

import json
from collections.abc import AsyncIterator
from typing import Any
from urllib.parse import unquote

import aiohttp
import pytest
from openapi_core import OpenAPI
from openapi_core.testing import MockRequest, MockResponse
from openapi_schema_validator import OAS30Validator

from server.ctrlx import SseParser, SubscriptionSettings, encode_node_path
from tests.ctrlx.helpers import KIN12, Mock, running
from tests.mock_ctrlx.spec import (
    DL,
    DL_API,
    FIXED_DL,
    IM,
    IM_API,
    NODE,
    RAW_DL,
    VALUE_SCHEMAS,
    _read_type_parameter,
    check_request,
    component,
    parse_event_stream,
)


def test_errata_are_needed() -> None:
    one = RAW_DL["paths"]["/events/{SubscriptionName}"]
    assert "404" not in one["get"]["responses"]
    assert "404" in one["delete"]["responses"] and "404" in one["put"]["responses"]
    assert "within one minute" in RAW_DL["paths"]["/events"]["post"]["description"]
    schema = _read_type_parameter(RAW_DL)["schema"]
    assert not OAS30Validator(schema).is_valid(schema["default"])
    # Data.value: "type: object", yet its own example holds a string; a double is a number.
    data_example = RAW_DL["components"]["schemas"]["Data"]["example"]
    assert not component(RAW_DL, "Data").is_valid(data_example)
    double = {"type": "double", "value": 1.5}
    assert not component(RAW_DL, "Data").is_valid(double)
    raw_enum = RAW_DL["components"]["schemas"]["Data"]["properties"]["type"]["enum"]
    assert set(VALUE_SCHEMAS) == set(raw_enum)  # every type the description names
    fixed_data = component(FIXED_DL, "Data")
    for good in (double, {"type": "arfloat64", "value": [1.0]}, {"type": "object", "value": {}}):
        assert fixed_data.is_valid(good), good
    # The correction still checks the value, by its type (the published "object" included).
    for bad in ({"type": "double", "value": "1.5"}, {"type": "object", "value": 1.5},
                {"type": "arstring", "value": "{}"}, {"type": "bool8", "value": 1}):  # fmt: skip
        assert not fixed_data.is_valid(bad), bad
    # SSE_EventData.value: "type: string", yet its own stream example holds objects.
    stream_example = RAW_DL["paths"]["/events"]["get"]["responses"]["200"]["content"][
        "text/event-stream"
    ]["example"]
    events = parse_event_stream(stream_example.replace(" \n", "\n").encode() + b"\n\n")
    assert events and all(isinstance(e["data"]["value"], dict) for e in events)
    typed = {**events[1]["data"], "event": "update"}
    assert typed["type"] == "object"
    assert not component(RAW_DL, "SSE_EventData").is_valid(typed)
    fixed_event = component(FIXED_DL, "SSE_EventData")
    assert fixed_event.is_valid(typed)
    keepalive = {"event": "keepalive", "node": "", "timestamp": 1, "value": ""}
    assert fixed_event.is_valid(keepalive) and not fixed_event.is_valid({**keepalive, "value": 1})
    assert not fixed_event.is_valid({**typed, "type": "double"})
    # ReadNode's 200: a browse answer is a Data and a BrowseData, so "oneOf" refuses it.
    browse = {"type": "arstring", "value": ["motion"]}
    read_ok = RAW_DL["paths"]["/nodes/{Path}"]["get"]["responses"]["200"]["content"][
        "application/json"
    ]["schema"]
    assert not OAS30Validator({**read_ok, "components": RAW_DL["components"]}).is_valid(browse)
    fixed_read = FIXED_DL["paths"]["/nodes/{Path}"]["get"]["responses"]["200"]["content"][
        "application/json"
    ]["schema"]
    fixed_read_validator = OAS30Validator({**fixed_read, "components": FIXED_DL["components"]})
    assert fixed_read_validator.is_valid(browse)
    assert not fixed_read_validator.is_valid({"type": "double", "value": "1.5"})


@pytest.fixture
async def mock() -> AsyncIterator[Mock]:
    async with running() as running_mock:
        yield running_mock


async def exchange(
    http: aiohttp.ClientSession,
    mock: Mock,
    api: OpenAPI,
    method: str,
    path: str,
    pattern: str,
    *,
    token: str | None = None,
    params: dict[str, str] | None = None,
    body: Any = None,
    validate_body: bool = True,
) -> tuple[int, Any]:
    """Send a request to the mock; check request and answer against ``api``."""
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    data = json.dumps(body).encode() if body is not None else None
    if data is not None:
        headers["Content-Type"] = "application/json"
    async with http.request(
        method, mock.url + path, params=params, data=data, headers=headers
    ) as resp:
        raw = await resp.read()
        status, content_type = resp.status, resp.content_type
    request = MockRequest(
        mock.url, method.lower(), path, path_pattern=pattern, args=params or {},
        view_args=path_arguments(path, pattern), headers=headers, data=data,
        content_type="application/json" if data else "",
    )  # fmt: skip
    check_request(api, request)
    if validate_body:
        api.validate_response(request, MockResponse(raw, status, content_type=content_type))
    else:
        declared = api.spec / "paths" / pattern[len(_base(pattern)) :] / method.lower()
        content = declared / "responses" / str(status) / "content"
        assert content_type in content, f"{status} {content_type} is not declared"
    return status, json.loads(raw) if raw and content_type == "application/json" else None


def path_arguments(path: str, pattern: str) -> dict[str, str]:
    """The value of a trailing ``{Name}`` of ``pattern`` in ``path`` (it may hold slashes)."""
    if "{" not in pattern:
        return {}
    prefix, name = pattern.split("{", 1)
    return {name.rstrip("}"): unquote(path[len(prefix) :])}


def _base(pattern: str) -> str:
    return DL if pattern.startswith(DL) else IM


async def login(http: aiohttp.ClientSession, mock: Mock) -> str:
    pattern = IM + "/auth/token"
    credentials = {"name": "boschrexroth", "password": "boschrexroth"}
    status, body = await exchange(http, mock, IM_API, "POST", pattern, pattern, body=credentials)
    assert status == 201
    return str(body["access_token"])


async def test_identity_manager(mock: Mock) -> None:
    pattern = IM + "/auth/token"
    async with aiohttp.ClientSession() as http:
        token = await login(http, mock)
        wrong = {"name": "boschrexroth", "password": "nope"}
        status, body = await exchange(http, mock, IM_API, "POST", pattern, pattern, body=wrong)
        assert status == 401 and body["title"] and body["type"] == "about:blank"
        validity = pattern + "/validity"
        _, body = await exchange(http, mock, IM_API, "GET", validity, validity, token=token)
        assert body == {"valid": True}
        status, _ = await exchange(http, mock, IM_API, "DELETE", pattern, pattern, token=token)
        assert status == 204
        _, body = await exchange(http, mock, IM_API, "GET", validity, validity, token=token)
        assert body == {"valid": False}


async def test_nodes_read_browse_metadata_and_problems(mock: Mock) -> None:
    actual = "motion/axs/kin12_a0/state/values/actual"
    async with aiohttp.ClientSession() as http:
        token = await login(http, mock)
        selected = {None: "Data", "browse": "BrowseData", "metadata": "MetaData"}
        for node, kind in [
            (KIN12[0], None), (actual, None), ("motion/axs", "browse"), (KIN12[0], "metadata"),
        ]:  # fmt: skip
            params = {"type": kind} if kind else None
            path = f"{DL}/nodes/{encode_node_path(node)}"
            status, body = await exchange(
                http, mock, DL_API, "GET", path, NODE, token=token, params=params,
                validate_body=False,
            )  # fmt: skip
            assert status == 200
            # ReadNode's 200 is oneOf [Data, MetaData, BrowseData], which overlap
            # (metadata has no "type: object"): check the one the query selects.
            component(FIXED_DL, selected[kind]).validate(body)
        for path, status_expected, tok in [
            (f"{DL}/nodes/motion/axs/nope/state/values/actual/pos", 404, token),
            (f"{DL}/nodes/{KIN12[0]}", 401, None),
            (f"{DL}/nodes/{KIN12[0]}", 401, "not-a-token"),
        ]:
            status, body = await exchange(http, mock, DL_API, "GET", path, NODE, token=tok)
            assert status == status_expected and body["status"] == status_expected
        cmd = f"{DL}/nodes/motion/axs/kin12_a0/cmd/pos-abs"
        status, _ = await exchange(
            http, mock, DL_API, "PUT", cmd, NODE, token=token,
            body={"type": "object", "value": {"axsPos": 10.0}},
        )  # fmt: skip
        assert status == 200


async def test_bulk(mock: Mock) -> None:
    pattern = DL + "/bulk"
    async with aiohttp.ClientSession() as http:
        token = await login(http, mock)
        for kind, items in [
            ("read", [{"address": n} for n in [*KIN12, "motion/axs/nope"]]),
            ("browse", [{"address": "motion/axs"}, {"address": "motion"}]),
            ("metadata", [{"address": KIN12[0]}]),
        ]:
            status, body = await exchange(
                http, mock, DL_API, "PUT", pattern, pattern, token=token,
                params={"type": kind}, body=items,
            )  # fmt: skip
            assert status == 200 and len(body) == len(items)
        assert body[0]["result"] == "DL_OK"


async def test_events_in_both_forms(mock: Mock) -> None:
    nodes = [*KIN12, "motion/axs/kin12_a0/state/values/actual", "motion/axs/nope"]
    event_validator = component(FIXED_DL, "SSE_Event")
    async with aiohttp.ClientSession() as http:
        token = await login(http, mock)
        # The client's own properties, so its request is checked against the description too.
        props = SubscriptionSettings(20, 100, 100).properties("conformance")
        status, _ = await exchange(
            http, mock, DL_API, "POST", DL + "/events", DL + "/events", token=token,
            body={"properties": props, "nodes": nodes},
        )  # fmt: skip
        assert status == 201
        for path, pattern, params in [
            (DL + "/events/conformance", DL + "/events/{SubscriptionName}", None),
            (DL + "/events", DL + "/events", {"nodes": ",".join(nodes), "publishIntervalMs": "20"}),
        ]:
            seen: set[str] = set()
            headers = {"Authorization": f"Bearer {token}", "Accept": "text/event-stream"}
            async with http.get(mock.url + path, params=params, headers=headers) as resp:
                request = MockRequest(mock.url, "get", path, path_pattern=pattern,
                                      args=params or {}, headers=headers,
                                      view_args=path_arguments(path, pattern))  # fmt: skip
                check_request(DL_API, request)
                assert resp.status == 200 and resp.content_type == "text/event-stream"
                parser = SseParser()
                while not {"update", "error"} <= seen:
                    for event in parser.feed(await resp.content.readany()):
                        envelope = {"id": float(event.id or 0), "event": event.event,
                                    "data": json.loads(event.data)}  # fmt: skip
                        event_validator.validate(envelope)
                        seen.add(event.event)
            assert {"update", "error"} <= seen
        status, _ = await exchange(
            http, mock, DL_API, "DELETE", DL + "/events/conformance",
            DL + "/events/{SubscriptionName}", token=token,
        )  # fmt: skip
        assert status == 200
