"""The publish loop's own parts: the lean decoder against asyncua's, and requests in batches."""

from __future__ import annotations

import asyncio
import datetime
import logging
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from asyncua import Server, ua
from asyncua.client.ua_client import UASocketProtocol
from asyncua.common.utils import Buffer
from asyncua.ua.ua_binary import struct_from_binary, struct_to_binary

from server.opcua.publish import BATCH, LOW, Changes, Publisher, decode
from server.sources import SourceError
from tests.conftest import free_port
from tests.opcua.helpers import IIWA, following, running

UTC = datetime.UTC
WHEN = datetime.datetime(2026, 11, 28, 15, 30, 0, 123456, tzinfo=UTC)


def response(*values: ua.DataValue | list[ua.DataValue], sequence: int = 7) -> bytes:
    """A PublishResponse as asyncua encodes it: one DataChangeNotification per list."""
    groups = [v if isinstance(v, list) else [v] for v in values]
    result = ua.PublishResponse()
    result.Parameters.SubscriptionId = 3
    result.Parameters.NotificationMessage.SequenceNumber = sequence
    result.Parameters.NotificationMessage.NotificationData = [
        ua.DataChangeNotification(
            MonitoredItems=[
                ua.MonitoredItemNotification(ClientHandle=10 * g + i, Value=value)
                for i, value in enumerate(group)
            ]
        )
        for g, group in enumerate(groups)
    ]
    return struct_to_binary(result)


def number(value: object, kind: ua.VariantType, **fields: Any) -> ua.DataValue:
    return ua.DataValue(ua.Variant(value, kind), **fields)


def asyncua_changes(data: bytes) -> list[tuple[int, float, float | None]]:
    """What asyncua's own decoder reads: the expected values."""
    parsed = struct_from_binary(ua.PublishResponse, Buffer(data)).Parameters
    return [
        (
            item.ClientHandle,
            float(item.Value.Value.Value),
            item.Value.SourceTimestamp.timestamp() if item.Value.SourceTimestamp else None,
        )
        for notification in parsed.NotificationMessage.NotificationData
        for item in notification.MonitoredItems
    ]


def test_good_numbers_decode_as_asyncua_decodes_them() -> None:
    data = response(
        [
            number(0.25, ua.VariantType.Double, SourceTimestamp=WHEN),
            number(-1.5, ua.VariantType.Float, SourceTimestamp=WHEN, ServerTimestamp=WHEN),
            number(-7, ua.VariantType.Int32),  # no time: None
            number(2**40, ua.VariantType.UInt64, SourceTimestamp=WHEN, SourcePicoseconds=5),
        ],
        [number(-3, ua.VariantType.SByte, SourceTimestamp=WHEN, ServerPicoseconds=9)],
        sequence=41,
    )
    changes = decode(data)
    assert isinstance(changes, Changes)
    assert (changes.subscription, changes.sequence) == (3, 41)
    expected = asyncua_changes(data)
    assert [c[:2] for c in changes.items] == [e[:2] for e in expected]
    for (*_, stamp), (*_, expected_stamp) in zip(changes.items, expected, strict=True):
        assert stamp == (
            None if expected_stamp is None else pytest.approx(expected_stamp, abs=1e-6)
        )
    assert changes.items[0] == (0, 0.25, pytest.approx(WHEN.timestamp(), abs=1e-6))


def test_a_keep_alive_decodes_as_no_changes() -> None:
    changes = decode(response())
    assert changes is not None and changes.items == [] and changes.sequence == 7


@pytest.mark.parametrize(
    "value",
    [
        number(
            1.0, ua.VariantType.Double, StatusCode=ua.StatusCode(ua.StatusCodes.BadSensorFailure)
        ),
        number(
            1.0,
            ua.VariantType.Double,
            StatusCode=ua.StatusCode(ua.StatusCodes.UncertainLastUsableValue),
        ),
        number(True, ua.VariantType.Boolean),
        number("1.0", ua.VariantType.String),
        number([1.0, 2.0], ua.VariantType.Double),
        ua.DataValue(ua.Variant()),
    ],
    ids=["bad status", "uncertain status", "boolean", "string", "array", "null"],
)
def test_anything_but_good_numbers_is_left_to_asyncua(value: ua.DataValue) -> None:
    # asyncua's objects then name it (the follower's error says the status or the type)
    assert decode(response([number(1.0, ua.VariantType.Double), value])) is None


def test_other_notifications_and_cut_responses_are_left_to_asyncua() -> None:
    status = ua.PublishResponse()
    status.Parameters.SubscriptionId = 3
    status.Parameters.NotificationMessage.NotificationData = [
        ua.StatusChangeNotification(Status=ua.StatusCode(ua.StatusCodes.BadTimeout))
    ]
    assert decode(struct_to_binary(status)) is None
    whole = response(number(0.5, ua.VariantType.Double, SourceTimestamp=WHEN))
    assert decode(whole) is not None
    for cut in range(len(whole)):
        assert decode(whole[:cut]) is None


async def test_the_server_always_holds_a_request_and_gets_them_in_batches(
    opcua_cache: Path,
) -> None:
    """asyncua's loop sends one request per response (the server holds none between);
    ours keeps LOW to LOW + BATCH there and writes BATCH at once."""
    async with running(opcua_cache) as mock, following(mock.url, IIWA) as run:
        await run.samples_after(10)
        (protocol,) = mock._clients()
        writes = [0]
        received = protocol.data_received

        def counted(data: bytes) -> None:
            writes[0] += 1
            received(data)

        protocol.data_received = counted  # type: ignore[method-assign]
        held = []
        first = len(run.samples)
        for _ in range(200):  # 1 s
            held.append(len(protocol.processor._publish_requests))
            await asyncio.sleep(0.005)
        samples = len(run.samples) - first
    assert samples >= 25
    assert min(held) >= 1 and max(held) <= LOW + BATCH
    # 50 requests a second in writes of BATCH (the watchdog's reads add one or two)
    assert writes[0] <= samples / 2


class _Protocol:
    """asyncua's request path stood in for: futures answered by the test."""

    logger = logging.getLogger("test")
    transport = None
    check_answer = UASocketProtocol.check_answer

    def __init__(self) -> None:
        self.sent: list[tuple[ua.PublishRequest, asyncio.Future[Any]]] = []

    def _send_request(self, request: ua.PublishRequest, timeout: float) -> asyncio.Future[Any]:
        future = asyncio.get_running_loop().create_future()
        self.sent.append((request, future))
        return future


def _fault(code: int) -> Buffer:
    fault = ua.ServiceFault()
    fault.ResponseHeader.ServiceResult = ua.StatusCode(code)
    return Buffer(struct_to_binary(fault))


async def test_a_server_keeping_fewer_requests_gets_smaller_batches_and_acknowledgements() -> None:
    protocol = _Protocol()
    got: list[object] = []
    client = SimpleNamespace(uaclient=SimpleNamespace(protocol=protocol))
    publisher = Publisher(client, got.append)  # type: ignore[arg-type]
    task = asyncio.create_task(publisher.run())
    await asyncio.sleep(0)
    assert len(protocol.sent) == BATCH + LOW
    protocol.sent[0][1].set_result(_fault(ua.StatusCodes.BadTooManyPublishRequests))
    await asyncio.sleep(0)
    assert publisher.batch == BATCH // 2
    data = response(number(1.0, ua.VariantType.Double), sequence=12)
    low = publisher.low
    answered = BATCH + LOW - 1 - low  # until no more than the (lower) LOW are left
    for _, future in protocol.sent[1 : 1 + answered]:
        future.set_result(Buffer(data))
        await asyncio.sleep(0)
    assert len(got) == answered
    assert len(protocol.sent) == BATCH + LOW + publisher.batch  # the next, smaller, batch
    request = protocol.sent[BATCH + LOW][0]  # the first of the new batch acknowledges them all
    acks = request.Parameters.SubscriptionAcknowledgements
    assert [(a.SubscriptionId, a.SequenceNumber) for a in acks] == [(3, 12)] * len(got)
    task.cancel()
    await asyncio.gather(task, return_exceptions=True)


async def test_values_the_lean_decoder_leaves_reach_the_source_named_by_asyncua() -> None:
    """A plain asyncua server (not the mock) writes a bad status between numbers."""
    server = Server()
    await server.init()
    index = await server.register_namespace("urn:test:plc")
    node = await server.nodes.objects.add_variable(ua.NodeId("Axis", index), "Axis", 0.0)
    server.set_endpoint(f"opc.tcp://127.0.0.1:{free_port()}")
    server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
    await server.start()
    key = "nsu=urn:test:plc;s=Axis"
    try:
        async with following(server.endpoint.geturl(), [key]) as run:
            for written, expected in (
                (ua.DataValue(ua.Variant(0.5, ua.VariantType.Double)), 0.5),
                (
                    ua.DataValue(
                        ua.Variant(0.5, ua.VariantType.Double),
                        StatusCode=ua.StatusCode(ua.StatusCodes.BadSensorFailure),
                    ),
                    "BadSensorFailure",
                ),
                (ua.DataValue(ua.Variant(-2.0, ua.VariantType.Double)), -2.0),
            ):
                await server.write_attribute_value(node.nodeid, written)  # with its status
                await run.until(
                    lambda e=expected: run.samples and _shows(run.samples[-1].values[key], e)
                )
    finally:
        await server.stop()


def _shows(value: float | Exception, expected: float | str) -> bool:
    if isinstance(expected, str):
        return isinstance(value, SourceError) and expected in str(value)
    return value == expected
