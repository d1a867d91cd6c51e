"""Subscriptions as a device keeps them: trailing slashes, string numbers, expiry, 409, PUT."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import aiohttp

from server.ctrlx import SseParser
from tests.ctrlx.helpers import IIWA, KIN12, Mock, running

DL, IM = "/automation/api/v2", "/identity-manager/api/v2"
PROPERTIES = f"{DL}/nodes/datalayer/subscriptions/clients/any/subscriptions"


async def headers_of(http: aiohttp.ClientSession, mock: Mock) -> dict[str, str]:
    credentials = {"name": "boschrexroth", "password": "boschrexroth"}
    async with http.post(f"{mock.url}{IM}/auth/token/", json=credentials) as resp:
        assert resp.status == 201  # the token route takes a trailing slash too
        return {"Authorization": f"Bearer {(await resp.json())['access_token']}"}


@asynccontextmanager
async def event_stream(
    http: aiohttp.ClientSession, url: str, headers: dict[str, str]
) -> AsyncIterator[aiohttp.ClientResponse]:
    async with http.get(url, headers={**headers, "Accept": "text/event-stream"}) as resp:
        assert resp.status == 200 and resp.content_type == "text/event-stream"
        yield resp


async def updated_nodes(resp: aiohttp.ClientResponse, count: int) -> set[str]:
    """The nodes of the next ``count`` update events (fails after 5 s)."""
    parser, seen, n = SseParser(), set(), 0
    async with asyncio.timeout(5):
        while n < count:
            for event in parser.feed(await resp.content.readany()):
                if event.event == "update":
                    seen.add(json.loads(event.data)["node"])
                    n += 1
    return seen


async def test_trailing_slash_on_every_collection_route() -> None:
    async with running() as mock, aiohttp.ClientSession() as http:
        headers = await headers_of(http, mock)
        body = {"properties": {"id": "slash"}, "nodes": KIN12}
        async with http.post(f"{mock.url}{DL}/events/", json=body, headers=headers) as resp:
            assert resp.status == 201
            assert resp.headers["Location"] == f"{DL}/events/slash"
        async with http.put(f"{mock.url}{DL}/bulk/", params={"type": "read"}, headers=headers,
                            json=[{"address": KIN12[0]}]) as resp:  # fmt: skip
            assert resp.status == 200 and (await resp.json())[0]["result"] == "DL_OK"
        async with http.get(f"{mock.url}{IM}/auth/token/validity/", headers=headers) as resp:
            assert (await resp.json()) == {"valid": True}
        async with http.get(f"{mock.url}{DL}/nodes/motion/axs/", headers=headers,
                            params={"type": "browse"}) as resp:  # fmt: skip
            assert "kin12_a0" in (await resp.json())["value"]
        async with event_stream(http, f"{mock.url}{DL}/events/slash/", headers) as resp:
            assert await updated_nodes(resp, 2) == set(KIN12)
        async with http.delete(f"{mock.url}{DL}/events/slash/", headers=headers) as resp:
            assert resp.status == 200


async def test_numbers_sent_as_strings_are_taken() -> None:
    async with running() as mock, aiohttp.ClientSession() as http:
        headers = await headers_of(http, mock)
        props = {"id": "s", "publishInterval": "20", "keepaliveInterval": "1500",
                 "errorInterval": " 300 "}  # fmt: skip
        async with http.post(f"{mock.url}{DL}/events", headers=headers,
                             json={"properties": props, "nodes": KIN12}) as resp:  # fmt: skip
            assert resp.status == 201
        async with http.get(f"{mock.url}{PROPERTIES}/s/properties", headers=headers) as resp:
            stored = (await resp.json())["value"]
        assert (stored["publishInterval"], stored["keepaliveInterval"]) == (20, 1500)
        assert stored["errorInterval"] == 300
        # 20 ms, not the default 1000 ms: 20 updates of two nodes arrive well within 5 s.
        async with event_stream(http, f"{mock.url}{DL}/events/s", headers) as resp:
            assert await updated_nodes(resp, 40) == set(KIN12)
        for bad in ("fast", True, -1, [20]):
            props = {"id": "bad", "publishInterval": bad}
            async with http.post(f"{mock.url}{DL}/events", headers=headers,
                                 json={"properties": props, "nodes": KIN12}) as resp:  # fmt: skip
                assert resp.status == 400, bad
                assert (await resp.json())["title"] == "DL_INVALID_VALUE"


async def test_unused_subscription_expires_after_its_lifetime() -> None:
    async with running(subscription_lifetime_s=0.3) as mock, aiohttp.ClientSession() as http:
        headers = await headers_of(http, mock)
        for sub_id in ("idle", "used"):
            body = {"properties": {"id": sub_id}, "nodes": KIN12}
            async with http.post(f"{mock.url}{DL}/events", headers=headers, json=body) as resp:
                assert resp.status == 201
        async with event_stream(http, f"{mock.url}{DL}/events/used", headers) as resp:
            await asyncio.sleep(0.5)  # longer than the lifetime, with a stream open
            assert len(mock.state.subscriptions) == 1  # "idle" is gone, "used" is not
            assert await updated_nodes(resp, 1)
        async with http.get(f"{mock.url}{DL}/events/idle", headers=headers) as resp:
            assert resp.status == 404 and (await resp.json())["title"] == "DL_INVALID_ADDRESS"
        async with event_stream(http, f"{mock.url}{DL}/events/used", headers) as resp:
            pass  # reopened within the lifetime after its last stream closed
        await asyncio.sleep(0.5)
        async with http.get(f"{mock.url}{DL}/events/used", headers=headers) as resp:
            assert resp.status == 404


async def test_delete_with_an_open_stream_is_a_conflict() -> None:
    async with running() as mock, aiohttp.ClientSession() as http:
        headers = await headers_of(http, mock)
        body = {"properties": {"id": "busy"}, "nodes": KIN12}
        async with http.post(f"{mock.url}{DL}/events", headers=headers, json=body) as resp:
            assert resp.status == 201
        async with event_stream(http, f"{mock.url}{DL}/events/busy", headers) as stream:
            async with http.delete(f"{mock.url}{DL}/events/busy", headers=headers) as resp:
                assert resp.status == 409
                body = await resp.json()
            assert body["status"] == 409 and "open event stream" in body["detail"]
            assert await updated_nodes(stream, 2) == set(KIN12)  # the stream goes on
        # Right after the client hung up, the delete goes through.
        async with http.delete(f"{mock.url}{DL}/events/busy", headers=headers) as resp:
            assert resp.status == 200
        async with http.delete(f"{mock.url}{DL}/events/busy", headers=headers) as resp:
            assert resp.status == 404


async def test_put_changes_the_nodes_of_an_open_stream() -> None:
    async with running() as mock, aiohttp.ClientSession() as http:
        headers = await headers_of(http, mock)
        props = {"id": "change", "publishInterval": 20}
        async with http.post(f"{mock.url}{DL}/events", headers=headers,
                             json={"properties": props, "nodes": KIN12}) as resp:  # fmt: skip
            assert resp.status == 201
        async with event_stream(http, f"{mock.url}{DL}/events/change", headers) as stream:
            assert await updated_nodes(stream, 4) == set(KIN12)
            async with http.put(f"{mock.url}{DL}/events/change", headers=headers,
                                json={"id": "change", "nodes": IIWA[:3]}) as resp:  # fmt: skip
                assert resp.status == 200
            seen = await updated_nodes(stream, 30)
        assert set(IIWA[:3]) <= seen and len(seen - set(KIN12)) == 3
        async with http.put(f"{mock.url}{DL}/events/nope", headers=headers,
                            json={"id": "nope", "nodes": KIN12}) as resp:  # fmt: skip
            assert resp.status == 404


async def test_commands_run_on_put_and_post_and_empty_argument_commands_take_no_body() -> None:
    async with running() as mock, aiohttp.ClientSession() as http:
        headers = await headers_of(http, mock)
        reset = f"{mock.url}{DL}/nodes/motion/axs/kin12_a0/cmd/reset"
        for method in ("PUT", "POST"):
            # Exactly what Node-RED sends for an empty-argument command: no body at all.
            plain = {**headers, "Accept": "application/json"}
            async with http.request(method, reset, headers=plain) as resp:
                assert resp.status == 200 and await resp.read() == b""
        async with http.put(f"{mock.url}{DL}/nodes/motion/grp/kin12/cmd/pos-abs",
                            headers=headers) as resp:  # fmt: skip
            assert resp.status == 400
            body = await resp.json()
        assert body["title"] == "DL_MISSING_ARGUMENT"
        assert body["instance"] == "motion/grp/kin12/cmd/pos-abs"
        target = {"type": "object", "value": {"axsPos": [14.0, -9.0]}}
        async with http.post(f"{mock.url}{DL}/nodes/motion/grp/kin12/cmd/pos-abs",
                             headers=headers, json=target) as resp:  # fmt: skip
            assert resp.status == 200
        async with asyncio.timeout(10):
            while mock.state.machine.group_positions("kin12").tolist() != [14.0, -9.0]:
                await asyncio.sleep(0.05)
        async with http.delete(f"{mock.url}{DL}/nodes/{KIN12[0]}", headers=headers) as resp:
            assert resp.status == 403 and (await resp.json())["instance"] == KIN12[0]
