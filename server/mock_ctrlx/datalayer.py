"""Data-layer node handlers: ``/nodes/{path}`` (GET, PUT, POST, DELETE) and ``PUT /bulk``."""

from __future__ import annotations

import re
from typing import Any

import orjson
from aiohttp import web

from ..ctrlx.timestamps import filetime_from_unix
from .nodes import NodeError, Snapshot, not_found
from .problems import problem, problem_body, request_problem
from .state import STATE_KEY, MockState

BULK_KINDS = ("read", "write", "create", "delete", "browse", "metadata")
_SUBSCRIPTION_NODE = re.compile(
    r"datalayer/subscriptions/clients/[^/]+/subscriptions/(?P<id>[^/]+)(?:/(?P<part>nodes|properties))?"
)


class BadBody(ValueError):
    """The request body is no JSON."""


async def json_body(request: web.Request) -> Any:
    """The JSON body of ``request``; None when it has none (empty-argument commands)."""
    raw = await request.read()
    if not raw.strip():
        return None
    try:
        return orjson.loads(raw)
    except orjson.JSONDecodeError as exc:
        raise BadBody("the body is not JSON") from exc


def node_problem(err: NodeError, node: str) -> web.Response:
    """The Problem answer for a failed operation on ``node`` (its address is the instance)."""
    return problem(err.status, err.title, err.detail, node.strip("/"), dynamic=node)


def _node(request: web.Request) -> str:
    return request.match_info.get("path", "").strip("/")  # percent-decoded; "" is the root


async def read_node(request: web.Request) -> web.Response:
    """GET /nodes/{path}[?type=browse|metadata]: value, children or metadata of a node."""
    state, node = request.app[STATE_KEY], _node(request)
    kind = request.query.get("type", "read")
    try:
        if kind == "browse":
            return web.json_response({"type": "arstring", "value": state.nodes.browse(node)})
        if kind == "metadata":
            return web.json_response({"type": "object", "value": state.nodes.metadata(node)})
        if kind not in ("read", "data"):
            return request_problem(request, 400, "DL_INVALID_VALUE", f"unknown type '{kind}'")
        # ``?data=`` (a read with an argument) is accepted; no node of the mock uses it.
        return web.json_response(read(state, node))
    except NodeError as err:
        return node_problem(err, node)


async def write_node(request: web.Request) -> web.Response:
    """PUT /nodes/{path}: write a value, or run a command (an empty body for no argument)."""
    return await _change(request, "write")


async def create_node(request: web.Request) -> web.Response:
    """POST /nodes/{path}: run a command (ctrlX motion takes commands as creates)."""
    return await _change(request, "create")


async def _change(request: web.Request, how: str) -> web.Response:
    state, node = request.app[STATE_KEY], _node(request)
    try:
        body = await json_body(request)
    except BadBody as exc:
        return request_problem(request, 400, "DL_TYPE_MISMATCH", str(exc))
    try:
        done = (state.nodes.write if how == "write" else state.nodes.create)(node, body)
    except NodeError as err:
        return node_problem(err, node)
    return web.Response(status=200) if done is None else web.json_response(done)


async def delete_node(request: web.Request) -> web.Response:
    """DELETE /nodes/{path}: refused for every node of the mock (403 or 404 Problem)."""
    node = _node(request)
    try:
        request.app[STATE_KEY].nodes.delete(node)
    except NodeError as err:
        return node_problem(err, node)
    return web.Response(status=204)


def read(state: MockState, node: str, snapshot: Snapshot | None = None) -> dict[str, Any]:
    """The Data of ``node``, the subscription nodes of ``datalayer/subscriptions`` included."""
    match = _SUBSCRIPTION_NODE.fullmatch(node)
    if match is None:
        return state.nodes.read(node, snapshot)
    spec = state.subscriptions.get(match["id"])
    if spec is None:
        raise not_found(node)
    if match["part"] == "nodes":
        return {"type": "arstring", "value": list(spec.nodes)}
    if match["part"] == "properties":
        return {"type": "object", "value": spec.properties()}
    return {"type": "object", "value": {"properties": spec.properties(), "nodes": spec.nodes}}


async def bulk(request: web.Request) -> web.Response:
    """PUT /bulk?type=read|write|create|delete|browse|metadata: many nodes in one round trip."""
    state = request.app[STATE_KEY]
    kind = request.query.get("type", "read")
    if kind not in BULK_KINDS:
        return request_problem(request, 400, "DL_INVALID_VALUE", f"unknown bulk type '{kind}'")
    try:
        items = await json_body(request)
        if not isinstance(items, list) or not all(
            isinstance(i, dict) and isinstance(i.get("address"), str) for i in items
        ):
            raise BadBody("expected [{'address': ...}, ...]")
    except BadBody as exc:
        return request_problem(request, 400, "DL_INVALID_VALUE", str(exc))
    t = state.machine.now()
    snapshot = Snapshot(state.machine, t)  # one instant for every node of the request
    stamp = str(filetime_from_unix(t))
    answer: list[dict[str, Any]] = []
    for item in items:
        node = item["address"].strip("/")
        entry: dict[str, Any] = {"address": item["address"], "timestamp": stamp}
        try:
            data = _bulk_one(state, kind, node, item, snapshot, t)
            entry["result"] = "DL_OK"
            if data is not None:
                entry.update(type=data["type"], value=data["value"])
        except NodeError as err:
            body = problem_body(err.status, err.title, err.detail, node, dynamic=node)
            entry.update(result=err.title, type="error", value=body)
        answer.append(entry)
    return web.json_response(answer)


def _bulk_one(
    state: MockState,
    kind: str,
    node: str,
    item: dict[str, Any],
    snapshot: Snapshot,
    t: float,
) -> dict[str, Any] | None:
    if kind == "read":
        return read(state, node, snapshot)
    if kind == "write":
        return state.nodes.write(node, item if "value" in item else None, t)
    if kind == "create":
        return state.nodes.create(node, item if "value" in item else None, t)
    if kind == "delete":
        state.nodes.delete(node)
        return None
    if kind == "browse":
        return {"type": "arstring", "value": state.nodes.browse(node)}
    return {"type": "object", "value": state.nodes.metadata(node)}
