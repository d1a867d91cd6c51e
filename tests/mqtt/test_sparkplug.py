"""Sparkplug B metrics as Eclipse Tahu's reference edge node client publishes them.

``clients/sparkplug_tahu/edge.js`` runs Tahu's ``sparkplug-client`` (npm, pinned in
its package-lock.json) under Node 20 against the test's Mosquitto: NBIRTH, DBIRTH, and
DDATA every 20 ms, by name or by alias, plain or compressed. Its metric values follow
0.5 sin(t) + offset, so every value read is checked against that band.
"""

from __future__ import annotations

import asyncio
import json
import shutil
import subprocess
import time
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import aiomqtt
import pytest

from server.mqtt import Mosquitto, sparkplug
from server.mqtt.nodes import parse_node
from server.mqtt.publisher import SparkplugEdge
from server.mqtt.sparkplug import Devices, SparkplugError
from tests.conftest import wait_until
from tests.mqtt.helpers import Follower

EDGE = Path(__file__).resolve().parents[1] / "clients" / "sparkplug_tahu" / "edge.js"
KEY = "spBv1.0/Plant/Cell1/Robot1"
AXIS1, AXIS2 = f"{KEY}#Axis 1/Position", f"{KEY}#Axis 2/Position"
METRICS = [
    {"name": "Axis 1/Position", "alias": 1, "type": "Double", "offset": 0.25},
    {"name": "Axis 2/Position", "alias": 2, "type": "Int16", "offset": -3},
    {"name": "Gripper/Closed", "alias": 3, "type": "Boolean", "offset": 0},
]


def axis1_ok(value: object) -> bool:
    return isinstance(value, float) and -0.25 <= value <= 0.75


def axis2_ok(value: object) -> bool:
    # Math.round(-3 + 0.5 sin t) in the edge node, an Int16 sent as a two's complement.
    return value in (-3.0, -2.0)


class Edge:
    """``edge.js`` publishing until closed; commands go to its stdin."""

    def __init__(self, broker: Mosquitto, **config: Any) -> None:
        node = shutil.which("node")
        assert node is not None, "Node 20 runs Tahu's client"
        config = {
            "url": f"tcp://{broker.host}:{broker.port}",
            "group": "Plant",
            "edge": "Cell1",
            "device": "Robot1",
            "metrics": METRICS,
            **config,
        }
        self.proc = subprocess.Popen(
            [node, str(EDGE), json.dumps(config)],
            stdin=subprocess.PIPE,
            text=True,
        )

    def command(self, line: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def close(self) -> None:
        self.proc.kill()
        self.proc.wait()
        if self.proc.stdin is not None:
            self.proc.stdin.close()


@pytest.fixture
def edge(broker: Mosquitto) -> Iterator[Callable[..., Edge]]:
    made: list[Edge] = []

    def start(**config: Any) -> Edge:
        made.append(Edge(broker, **config))
        return made[-1]

    yield start
    for e in made:
        e.close()


async def test_metrics_by_name_from_tahus_edge_node(
    follow: Callable[..., Follower], edge: Callable[..., Edge]
) -> None:
    follower = follow([AXIS1, AXIS2, f"{KEY}#Gripper/Closed", f"{KEY}#Axis 9"])
    tahu = edge()
    await follower.value(AXIS1, axis1_ok)  # DDATA by name: no birth needed
    await follower.value(AXIS2, axis2_ok)
    last = follower.samples[-1].values
    assert "is a boolean, not a number" in str(last[f"{KEY}#Gripper/Closed"])
    tahu.command("dbirth")  # one we are sure to see: the birth lists every metric
    missing = await follower.value(f"{KEY}#Axis 9", lambda v: "DBIRTH" in str(v))
    assert str(missing) == (
        f"{KEY}: its DBIRTH has no metric 'Axis 9' (it has 3: 'Axis 1/Position', "
        "'Axis 2/Position', 'Gripper/Closed')"
    )


async def test_values_by_alias_wait_for_a_birth_then_are_named_by_it(
    broker: Mosquitto, follow: Callable[..., Follower], edge: Callable[..., Edge]
) -> None:
    async with aiomqtt.Client(broker.host, broker.port) as probe:
        await probe.subscribe("spBv1.0/Plant/+/Cell1/Robot1")
        tahu = edge(aliasesOnly=True)
        async with asyncio.timeout(20):
            async for message in probe.messages:  # the broker keeps each publisher's order:
                if "DDATA" in message.topic.value:  # the births are gone by the first DDATA
                    break
    follower = follow([AXIS1, AXIS2])  # after the births: DDATA by alias alone
    waiting = await follower.value(AXIS1, lambda v: isinstance(v, SparkplugError))
    assert "no birth certificate came since linkview subscribed" in str(waiting)
    tahu.command("dbirth")
    await follower.value(AXIS1, axis1_ok)

    def moving() -> int:
        return len({s.values[AXIS1] for s in follower.samples if axis1_ok(s.values[AXIS1])})

    await wait_until(lambda: moving() > 5)  # the DDATAs, not the birth alone
    floats = [s.values[AXIS1] for s in follower.samples if isinstance(s.values[AXIS1], float)]
    assert all(axis1_ok(v) for v in floats), floats
    assert axis2_ok(follower.samples[-1].values[AXIS2])


async def test_a_device_death_and_its_nodes_death_take_it_offline_until_its_birth(
    follow: Callable[..., Follower], edge: Callable[..., Edge]
) -> None:
    follower = follow([AXIS1])
    tahu = edge()
    await follower.value(AXIS1, axis1_ok)
    tahu.command("ddeath")
    dead = await follower.value(AXIS1, lambda v: isinstance(v, SparkplugError))
    assert str(dead) == f"{KEY}: offline (DDEATH)"
    tahu.command("dbirth")
    await follower.value(AXIS1, axis1_ok)
    tahu.command("stop")  # the node's NDEATH
    dead = await follower.value(AXIS1, lambda v: isinstance(v, SparkplugError))
    assert str(dead) == f"{KEY}: offline (NDEATH of its edge node spBv1.0/Plant/Cell1)"


@pytest.mark.parametrize("algorithm", ["DEFLATE", "GZIP"])
async def test_compressed_payloads(
    algorithm: str, follow: Callable[..., Follower], edge: Callable[..., Edge]
) -> None:
    follower = follow([AXIS1, AXIS2])
    edge(compress=algorithm)
    await follower.value(AXIS1, axis1_ok)
    await follower.value(AXIS2, axis2_ok)


def test_node_keys_of_sparkplug_metrics() -> None:
    node = parse_node("spBv1.0/Plant/Cell1/Robot1#Axis 1/Position")
    assert (node.topic, node.metric, node.pointer) == (KEY, "Axis 1/Position", None)
    assert parse_node("spBv1.0/Plant/Cell1#Temp").topic == "spBv1.0/Plant/Cell1"
    for bad in (
        "spBv1.0/Plant/Cell1/Robot1",  # no metric
        "spBv1.0/Plant/DDATA/Cell1/Robot1#Axis 1",  # the message type is not part of it
        "spBv1.0/Plant#Axis 1",
        "spBv1.0/Plant/Cell1/Robot1/Extra#Axis 1",
    ):
        with pytest.raises(ValueError, match="spBv1.0/GROUP/EDGE"):
            parse_node(bad)


def payload(**fields: Any) -> Any:
    return sparkplug.Payload(**fields)


def test_hostile_payloads_are_named_not_followed() -> None:
    devices = Devices({KEY: {"a"}})
    garbage = devices.received("DDATA", KEY, b"\xff\xff\xff\xff not protobuf")
    assert "not Sparkplug B" in str(garbage[KEY]["a"])
    # 100 MiB of zeros in 100 kB: inflated only as far as the limit, then refused.
    bomb = payload(uuid=sparkplug.COMPRESSED, body=zlib.compress(bytes(100 << 20), 9))
    started = time.process_time()
    refused = devices.received("DDATA", KEY, bomb.SerializeToString())
    assert "inflating past 4 MiB" in str(refused[KEY]["a"])
    assert time.process_time() - started < 5
    odd = payload(uuid=sparkplug.COMPRESSED, body=b"x")
    odd.metrics.add(name="algorithm", string_value="LZMA")
    assert "'LZMA'" in str(devices.received("DDATA", KEY, odd.SerializeToString())[KEY]["a"])


def test_values_that_are_no_numbers_and_past_values() -> None:
    devices = Devices({KEY: {"a", "b", "c"}})
    birth = payload()
    birth.metrics.add(name="a", alias=1, datatype=10, double_value=float("nan"))
    birth.metrics.add(name="b", alias=2, datatype=10, is_null=True)
    birth.metrics.add(name="c", alias=3, datatype=12, string_value="12")
    values = devices.received("DBIRTH", KEY, birth.SerializeToString())[KEY]
    assert "nan is not a finite number" in str(values["a"])
    assert "null" in str(values["b"]) and "string, not a number" in str(values["c"])
    data = payload()
    data.metrics.add(alias=1, datatype=10, double_value=2.5)
    data.metrics.add(alias=1, datatype=10, double_value=9.0, is_historical=True)
    data.metrics.add(alias=2, datatype=4, long_value=(1 << 64) - 7)  # Int64 -7
    assert devices.received("DDATA", KEY, data.SerializeToString())[KEY] == {"a": 2.5, "b": -7.0}


def test_the_will_of_an_earlier_session_does_not_kill_the_node() -> None:
    edge = "spBv1.0/Plant/Cell1"
    devices = Devices({KEY: {"a"}})
    birth = payload()
    birth.metrics.add(name="bdSeq", datatype=8, long_value=5)
    devices.received("NBIRTH", edge, birth.SerializeToString())
    old_will = payload()
    old_will.metrics.add(name="bdSeq", datatype=8, long_value=4)
    assert devices.received("NDEATH", edge, old_will.SerializeToString()) == {}
    will = payload()
    will.metrics.add(name="bdSeq", datatype=8, long_value=5)
    assert "offline" in str(devices.received("NDEATH", edge, will.SerializeToString())[KEY]["a"])


def test_the_embedded_mock_publishes_births_then_values_by_alias() -> None:
    nodes = {k: parse_node(k) for k in (AXIS1, AXIS2, "spBv1.0/Plant/Cell1#Temp")}
    edge = SparkplugEdge(nodes)
    values = {AXIS1: 0.5, AXIS2: -1.0, "spBv1.0/Plant/Cell1#Temp": 20.0}
    births = edge.births(values, 0)
    assert list(births) == ["spBv1.0/Plant/NBIRTH/Cell1", "spBv1.0/Plant/DBIRTH/Cell1/Robot1"]
    data = edge.data({**values, AXIS1: 0.75}, 20)
    assert set(data) == {"spBv1.0/Plant/NDATA/Cell1", "spBv1.0/Plant/DDATA/Cell1/Robot1"}
    devices = Devices({KEY: {"Axis 1/Position", "Axis 2/Position"}})
    devices.received("DBIRTH", KEY, births["spBv1.0/Plant/DBIRTH/Cell1/Robot1"])
    read = devices.received("DDATA", KEY, data["spBv1.0/Plant/DDATA/Cell1/Robot1"])
    assert read == {KEY: {"Axis 1/Position": 0.75, "Axis 2/Position": -1.0}}
    assert not any(
        m.name for m in sparkplug.decode(data["spBv1.0/Plant/DDATA/Cell1/Robot1"]).metrics
    )
