"""The live Foxglove endpoint, seen by a small client of the published protocol.

The client follows Foxglove's WebSocket protocol specification: JSON
``serverInfo`` and ``advertise`` from the server, a JSON ``subscribe`` from the
client, then binary message-data frames (opcode 1, u32 subscription id, u64
log time in ns, the message). It offers the specification's subprotocol
``foxglove.websocket.v1`` and ``foxglove.sdk.v1``, the same protocol under the
name foxglove-sdk's server accepts (it refuses the old name alone).
"""

from __future__ import annotations

import asyncio
import base64
import json
import struct
from typing import Any

import aiohttp
import numpy as np
import pytest
from mcap.records import Schema
from mcap_protobuf.decoder import DecoderFactory
from websockets.asyncio.client import connect
from websockets.exceptions import InvalidStatus

from server.config import Settings
from server.history import decode_binary
from tests.conftest import free_port, running_server

SUBPROTOCOLS: list[Any] = ["foxglove.websocket.v1", "foxglove.sdk.v1"]
MESSAGE_DATA = 1


async def subscribe_and_collect(url: str, topic: str, count: int) -> tuple[dict[str, Any], list]:
    """The channel of ``topic`` and ``count`` decoded messages received on it."""
    async with connect(url, subprotocols=SUBPROTOCOLS, max_size=None) as ws:
        assert ws.subprotocol in SUBPROTOCOLS
        channels: dict[str, dict[str, Any]] = {}
        async with asyncio.timeout(20):
            info = json.loads(await ws.recv())
            assert info["op"] == "serverInfo"
            while topic not in channels:
                message = await ws.recv()
                if isinstance(message, str) and json.loads(message)["op"] == "advertise":
                    for channel in json.loads(message)["channels"]:
                        channels[channel["topic"]] = channel
            channel = channels[topic]
            request = {"op": "subscribe", "subscriptions": [{"id": 7, "channelId": channel["id"]}]}
            await ws.send(json.dumps(request))
            schema = Schema(
                id=1,
                name=channel["schemaName"],
                encoding=channel["schemaEncoding"],
                data=base64.b64decode(channel["schema"]),
            )
            decoder: Any = DecoderFactory().decoder_for(channel["encoding"], schema)
            if channel["encoding"] == "json":
                decoder = json.loads
            assert decoder is not None
            frames: list[bytes] = []  # kept as they come; decoded once all are in
            while len(frames) < count:
                data = await ws.recv()
                if isinstance(data, bytes):
                    frames.append(data)
    received = []
    for data in frames:
        opcode, subscription, log_time = struct.unpack_from("<BIQ", data)
        assert opcode == MESSAGE_DATA and subscription == 7
        received.append((log_time, decoder(data[13:])))
    return channel, received


async def test_a_client_subscribes_and_receives_every_sample_s_transforms() -> None:
    port = free_port()
    async with running_server(Settings(foxglove_port=port)) as base:
        channel, received = await subscribe_and_collect(f"ws://127.0.0.1:{port}/", "/tf", 90)
        async with aiohttp.ClientSession() as http, http.get(f"{base}/api/history") as r:
            assert r.status == 200
        stamps = []
        for _, message in received:
            parents = {t.parent_frame_id for t in message.transforms}
            if parents == {"kin12/base"}:
                stamp = message.transforms[0].timestamp
                stamps.append(stamp.seconds + stamp.nanos * 1e-9)
        params = {"source": "demo", "from": repr(stamps[0] - 1e-6), "to": repr(stamps[-1] + 1e-6)}
        async with aiohttp.ClientSession() as http:
            async with http.get(f"{base}/api/history", params={**params, "poses": "none"}) as r:
                window = decode_binary(await r.read())
    assert channel["schemaName"] == "foxglove.FrameTransforms"
    assert len(stamps) >= 20
    # A transform for every sample the source delivered meanwhile. No rate is asked of this
    # reader: foxglove-sdk keeps up to 1024 messages per client (message_backlog_size) and
    # drops only past that, and the reader takes 90, storing them as they come.
    np.testing.assert_allclose(stamps, window["t"], atol=1e-6)


async def test_with_a_viewer_token_only_clients_with_it_connect() -> None:
    port = free_port()
    settings = Settings(foxglove_port=port, viewer_token="s3cret")
    async with running_server(settings):
        with pytest.raises(InvalidStatus) as refused:
            async with connect(f"ws://127.0.0.1:{port}/", subprotocols=SUBPROTOCOLS):
                pass
        assert refused.value.response.status_code == 401
        with pytest.raises(InvalidStatus):
            url = f"ws://127.0.0.1:{port}/?token=wrong"
            async with connect(url, subprotocols=SUBPROTOCOLS):
                pass
        url = f"ws://127.0.0.1:{port}/?token=s3cret"
        channel, received = await subscribe_and_collect(url, "/iiwa7/joints", 5)
    assert channel["encoding"] == "json"
    assert set(received[0][1]["position"]) == {f"a{i}" for i in range(1, 8)}
