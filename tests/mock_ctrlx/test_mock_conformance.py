"""The mock answers as the published ctrlX OpenAPI descriptions say (validated with openapi-core).

The descriptions are vendored, unmodified, in ``tests/specs/ctrlx`` (see its ORIGIN.md).
Where a description contradicts itself, the smallest correction is applied
to the loaded document (``ERRATA``); a test proves each one is needed.
"""

from __future__ import annotations

import copy
import json
import warnings
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any
from urllib.parse import unquote

import aiohttp
import pytest
from openapi_core import Config, OpenAPI
from openapi_core.testing import MockRequest, MockResponse
from openapi_schema_validator import OAS30Validator

from server.ctrlx import SseParser, SubscriptionSettings, encode_node_path
from tests.ctrlx.helpers import KIN12, Mock, running

SPECS = Path(__file__).resolve().parent.parent / "specs" / "ctrlx"
DL_FILE, IM_FILE = "datalayer.v2.1.5.openapi.json", "identitymanager.v2.10.0.openapi.json"
DL, IM = "/automation/api/v2", "/identity-manager/api/v2"
NODE = DL + "/nodes/{Path}"


def _load(name: str) -> dict[str, Any]:
    path = SPECS / name
    assert path.is_file(), f"the ctrlX OpenAPI description {path} is missing"
    document: dict[str, Any] = json.loads(path.read_text())
    return document


RAW_DL = _load(DL_FILE)
RAW_IM = _load(IM_FILE)


def _errata(document: dict[str, Any]) -> dict[str, Any]:
    """The data-layer description with its self-contradictions corrected.

    * ``Data.value`` says ``type: object``, yet the description's own Data
      example holds a string, and a double node holds a number.
    * ``SSE_EventData.value`` says ``type: string``, yet the description's own
      event-stream example holds objects.
    * ReadNode's query parameter ``type`` has ``default: 'null'``, outside its
      own enum (so a read without ``?type=`` would count as invalid).
    """
    fixed = copy.deepcopy(document)
    del _read_type_parameter(fixed)["schema"]["default"]
    schemas = fixed["components"]["schemas"]
    del schemas["Data"]["properties"]["value"]["type"]
    del schemas["SSE_EventData"]["properties"]["value"]["type"]
    return fixed


def _read_type_parameter(document: dict[str, Any]) -> dict[str, Any]:
    parameters = document["paths"]["/nodes/{Path}"]["get"]["parameters"]
    found: dict[str, Any] = next(p for p in parameters if p["name"] == "type")
    return found


FIXED_DL = _errata(RAW_DL)
# The data-layer description fails its own meta-schema ("default: 'null'" outside its
# enum), so openapi-core's check of the description itself is switched off.
CONFIG = Config(spec_validator_cls=None)
DL_API = OpenAPI.from_dict(FIXED_DL, config=CONFIG)
IM_API = OpenAPI.from_dict(copy.deepcopy(RAW_IM), config=CONFIG)


def check_request(api: OpenAPI, request: MockRequest) -> None:
    """Validate a request we sent (bearer security included)."""
    with warnings.catch_warnings():
        # openapi-core cannot evaluate the oauth2 alternative of the security list.
        warnings.filterwarnings("ignore", "Unsupported scheme type", UserWarning)
        api.validate_request(request)


def component(document: dict[str, Any], name: str) -> OAS30Validator:
    """A validator for ``#/components/schemas/<name>`` of ``document``."""
    root = {"$ref": f"#/components/schemas/{name}", "components": document["components"]}
    return OAS30Validator(root)


def test_errata_are_needed() -> None:
    schema = _read_type_parameter(RAW_DL)["schema"]
    assert not OAS30Validator(schema).is_valid(schema["default"])
    data_example = RAW_DL["components"]["schemas"]["Data"]["example"]
    assert not component(RAW_DL, "Data").is_valid(data_example)
    assert component(FIXED_DL, "Data").is_valid(data_example)
    stream_example = RAW_DL["paths"]["/events"]["get"]["responses"]["200"]["content"][
        "text/event-stream"
    ]["example"]
    events = SseParser().feed(stream_example.replace(" \n", "\n").encode() + b"\n\n")
    assert events and all(isinstance(json.loads(e.data)["value"], dict) for e in events)
    sse_data = {**json.loads(events[0].data), "event": "update"}
    assert not component(RAW_DL, "SSE_EventData").is_valid(sse_data)
    assert component(FIXED_DL, "SSE_EventData").is_valid(sse_data)


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
