"""linkview's MQTT client against Debian's Mosquitto, started per test on a free loopback port."""

from __future__ import annotations

import asyncio
import ssl
import subprocess
from collections.abc import Callable
from pathlib import Path

import aiomqtt
import pytest

from server.mock_ctrlx import make_certificate
from server.mqtt import Mosquitto, MqttConnector, MqttSettings, NoMessageYet, PayloadError
from server.mqtt.nodes import parse_node
from server.mqtt.publisher import document
from server.sources import Sample, SourceError
from tests.conftest import free_port, wait_until
from tests.mqtt.helpers import Follower, publish


async def keep_publishing(broker: Mosquitto, topic: str, payload: bytes) -> asyncio.Task[None]:
    """Publish ``payload`` every 20 ms until cancelled (the follower may subscribe late)."""

    async def run() -> None:
        async with aiomqtt.Client(broker.host, broker.port) as client:
            while True:
                await client.publish(topic, payload)
                await asyncio.sleep(0.02)

    return asyncio.create_task(run())


async def test_plain_numbers_one_topic_per_joint(
    broker: Mosquitto, follow: Callable[..., Follower]
) -> None:
    follower = follow(["cell/arm/j1", "cell/arm/j2"])
    tasks = [
        await keep_publishing(broker, "cell/arm/j1", b"12.5"),
        await keep_publishing(broker, "cell/arm/j2", b" -3e-1\n"),
    ]
    try:
        assert await follower.value("cell/arm/j1", lambda v: v == 12.5) == 12.5
        assert await follower.value("cell/arm/j2", lambda v: v == -0.3) == -0.3
        assert follower.connector.warning is None
    finally:
        for task in tasks:
            task.cancel()


async def test_json_payload_values_found_by_json_pointer(
    broker: Mosquitto, follow: Callable[..., Follower]
) -> None:
    nodes = ["cell/arm/state#/joints/0", "cell/arm/state#/joints/3", "cell/arm/state#/a~1b"]
    follower = follow(nodes)
    # RFC 6901: /joints/3 is the array's fourth item; ~1 stands for / in a member name.
    payload = b'{"joints": [0.5, 1.5, 2.5, 3.5], "a/b": 7}'
    task = await keep_publishing(broker, "cell/arm/state", payload)
    try:
        await follower.value(nodes[0], lambda v: v == 0.5)
        values = follower.samples[-1].values
        assert [values[n] for n in nodes] == [0.5, 3.5, 7.0]
    finally:
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)
    # One message per cycle on the one topic: the samples stand for every message, each
    # counted once (a late reader merges several; on a quiet machine each is one).
    await wait_until(
        lambda: sum(s.received for s in follower.samples) == follower.connector.messages
    )
    assert all(s.received >= 1 for s in follower.samples)


async def test_a_retained_message_is_the_last_value_of_unknown_age_until_a_live_one(
    broker: Mosquitto, follow: Callable[..., Follower]
) -> None:
    await publish(broker, "cell/arm/j1", b"42", retain=True)
    follower = follow(["cell/arm/j1"])
    assert await follower.value("cell/arm/j1", lambda v: v == 42.0) == 42.0
    assert follower.connector.warning == "last value, age unknown (retained message on cell/arm/j1)"
    await publish(broker, "cell/arm/j1", b"43")
    await follower.value("cell/arm/j1", lambda v: v == 43.0)
    assert follower.connector.warning is None


async def test_a_malformed_payload_is_named_and_spoils_only_its_nodes(
    broker: Mosquitto, follow: Callable[..., Follower]
) -> None:
    nodes = ["cell/a/j1", "cell/b/state#/joints/1", "cell/c/state#/x", "cell/ok"]
    follower = follow(nodes)
    tasks = [
        await keep_publishing(broker, "cell/a/j1", b"twelve"),
        await keep_publishing(broker, "cell/b/state", b'{"joints": [1.0]}'),
        await keep_publishing(broker, "cell/c/state", b"{not json"),
        await keep_publishing(broker, "cell/ok", b"1"),
    ]
    try:
        await wait_until(
            lambda: (
                bool(follower.samples)
                and all(not isinstance(follower.samples[-1].values[n], NoMessageYet) for n in nodes)
            )
        )
        values = follower.samples[-1].values
        assert isinstance(values["cell/a/j1"], PayloadError)
        assert str(values["cell/a/j1"]) == "cell/a/j1: payload 'twelve' is not a number"
        assert str(values[nodes[1]]) == "cell/b/state: /joints/1: the array has 1 items"
        assert str(values[nodes[2]]) == "cell/c/state: payload '{not json' is not JSON"
        assert values["cell/ok"] == 1.0
    finally:
        for task in tasks:
            task.cancel()


async def test_a_topic_without_messages_says_so(
    broker: Mosquitto, follow: Callable[..., Follower]
) -> None:
    follower = follow(["cell/quiet", "cell/ok"])
    task = await keep_publishing(broker, "cell/ok", b"1")
    try:
        await follower.value("cell/ok", lambda v: v == 1.0)
        quiet = follower.samples[-1].values["cell/quiet"]
        assert isinstance(quiet, NoMessageYet)
        assert str(quiet) == "cell/quiet: no message since linkview subscribed"
    finally:
        task.cancel()


async def test_a_broker_restart_is_ridden_out(
    broker: Mosquitto, follow: Callable[..., Follower]
) -> None:
    follower = follow(["cell/arm/j1"])
    await publish(broker, "cell/arm/j1", b"1", retain=True)
    await follower.value("cell/arm/j1", lambda v: v == 1.0)
    await broker.stop()
    await broker.start()  # same port; no persistence: the retained message is gone
    task = await keep_publishing(broker, "cell/arm/j1", b"2")
    try:
        assert await follower.value("cell/arm/j1", lambda v: v == 2.0) == 2.0
    finally:
        task.cancel()


async def test_a_broker_that_is_not_there_is_a_source_error_naming_it() -> None:
    port = free_port()
    connector = MqttConnector(MqttSettings(f"mqtt://127.0.0.1:{port}", timeout_s=2.0))
    with pytest.raises(SourceError, match=rf"^mqtt://127\.0\.0\.1:{port}: "):
        await asyncio.wait_for(connector.follow(["a"], 0.02, lambda _: None), 10.0)


async def test_wrong_credentials_are_refused_and_named(tmp_path: Path) -> None:
    passwords = tmp_path / "passwords"
    subprocess.run(
        ["mosquitto_passwd", "-c", "-b", str(passwords), "viewer", "right"],
        check=True,
        capture_output=True,
    )
    mosquitto = Mosquitto(port=free_port(), passwords=passwords)
    await mosquitto.start()
    try:
        wrong = MqttConnector(MqttSettings(mosquitto.url, user="viewer", password="wrong"))
        with pytest.raises(SourceError, match="Not authorized|[Bb]ad user name or password"):
            await asyncio.wait_for(wrong.follow(["a"], 0.02, lambda _: None), 10.0)
        right = MqttConnector(MqttSettings(mosquitto.url, user="viewer", password="right"))
        samples: list[Sample] = []
        task = asyncio.create_task(right.follow(["a"], 0.02, samples.append))
        try:
            async with aiomqtt.Client(
                mosquitto.host, mosquitto.port, username="viewer", password="right"
            ) as client:
                async with asyncio.timeout(10):
                    while not samples:
                        await client.publish("a", b"5")
                        await asyncio.sleep(0.05)
            assert samples[-1].values["a"] == 5.0
        finally:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
    finally:
        await mosquitto.close()


def test_node_keys_split_topic_and_json_pointer() -> None:
    assert parse_node("cell/arm/j1").pointer is None
    assert parse_node("cell/arm/state#/joints/3").pointer == ("joints", "3")
    assert parse_node("t#").pointer == ()  # the whole document (RFC 6901: "")
    for bad in ("cell/+/j1", "#/joints/0", "t#joints/0"):
        with pytest.raises(ValueError):
            parse_node(bad)


def test_the_mock_publisher_builds_json_that_the_pointers_find() -> None:
    built = document([(("joints", "1"), 2.0), (("joints", "0"), 1.0), (("tcp", "x"), 3.0)])
    assert built == {"joints": [1.0, 2.0], "tcp": {"x": 3.0}}


async def test_tls_with_the_brokers_certificate_and_refused_without(tmp_path: Path) -> None:
    cert = make_certificate(tmp_path)
    mosquitto = Mosquitto(port=free_port(), tls=(cert.cert_file, cert.key_file))
    await mosquitto.start()
    try:
        assert mosquitto.url.startswith("mqtts://")
        unchecked = MqttConnector(MqttSettings(mosquitto.url))  # the system's CAs: not ours
        with pytest.raises(SourceError, match="CERTIFICATE_VERIFY_FAILED|certificate verify"):
            await asyncio.wait_for(unchecked.follow(["a"], 0.02, lambda _: None), 10.0)
        trusted = MqttConnector(MqttSettings(mosquitto.url, ca=cert.ca_file))
        samples: list[Sample] = []
        task = asyncio.create_task(trusted.follow(["a"], 0.02, samples.append))
        try:
            context = ssl.create_default_context(cafile=str(cert.ca_file))
            async with aiomqtt.Client(
                mosquitto.host, mosquitto.port, tls_context=context
            ) as client:
                async with asyncio.timeout(10):
                    while not samples:
                        await client.publish("a", b"7")
                        await asyncio.sleep(0.05)
            assert samples[-1].values["a"] == 7.0
            assert trusted.warning is None
        finally:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
    finally:
        await mosquitto.close()


def test_standing_warnings_name_a_login_in_clear_and_an_unchecked_broker() -> None:
    clear = MqttConnector(MqttSettings("mqtt://10.1.2.3", user="viewer", password="x"))
    assert clear.warning == "mqtt:// with a login: the password travels in clear (use mqtts://)"
    unchecked = MqttConnector(MqttSettings("mqtts://10.1.2.3", insecure=True))
    assert unchecked.warning == "the broker's TLS certificate is not checked (insecure)"
    assert MqttConnector(MqttSettings("mqtt://127.0.0.1", user="viewer")).warning is None
