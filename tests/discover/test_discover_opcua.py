"""``discover opc.tcp://...``: on the mock, on a Robotics server the test builds, under a folder."""

from __future__ import annotations

import asyncio
import datetime as dt
import math
import tomllib
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path

import numpy as np
from asyncua import Server, ua

from server.cell import Cell, load_cell
from server.mock_ctrlx import Machine
from server.mock_opcua.address_space import NODESETS_DIR
from server.runtime import Runtime
from server.stream import SourceHealth
from tests.conftest import free_port, wait_until
from tests.discover.test_discover_rtde import discover
from tests.opcua.helpers import running

ACME = "http://acme.example/cell7/"
UNECE = "http://www.opcfoundation.org/UA/units/un/cefact"
RADIAN, DEGREE, MILLIMETRE = 4405297, 17476, 5066068  # OPC Foundation's UNECE_to_OPCUA.csv
HOSTILE = 'ACME "robots"\x1b[2J\nallow_commands = true\n[[source]]\nname = "evil"'


async def streamed(cell: Cell, robot: str) -> tuple[Runtime, SourceHealth]:
    """A runtime following ``cell``, once ``robot`` has frames."""
    runtime = await Runtime.start(cell)
    health = next(h for h in runtime.healths() if robot in {r.name for r in cell.robots_of(h.name)})

    def framed() -> bool:
        state = health.robots.get(robot)
        return state is not None and state.ok and state.frames > 5

    try:
        await wait_until(framed, 30.0)
    except BaseException:
        await runtime.stop()
        raise
    return runtime, health


async def test_discover_on_the_mock_writes_a_cell_that_check_accepts_and_streams(
    opcua_cache: Path, tmp_path: Path
) -> None:
    machine = Machine()
    async with running(opcua_cache, machine) as mock:
        output = tmp_path / "plant.toml"
        code, out, err = await discover(mock.url, "-o", str(output), cwd=tmp_path)
        assert code == 0, err
        assert "KUKA LBR iiwa 7 R800" in out and "3 motion devices" in out
        cell = load_cell(output, env={}, cache_dir=tmp_path / "cache")
        robots = {r.name: r for r in cell.robots}
        assert {name: r.family for name, r in robots.items()} == {
            "kin12": "type12",  # known models get their tables
            "iiwa": "dh",
            "pos": "axis_group",  # the rest: a placeholder chain that runs
        }
        assert all(j.unit_from_device for r in cell.robots for j in r.joints)
        runtime, health = await streamed(cell, "iiwa")
        try:
            values = health.robots["iiwa"].values
            assert values is not None
            # Each node is read as the simulated axis; the demo arm keeps within its limits.
            assert np.all(np.abs(values) <= [119.0, 84.0, 119.0, 84.0, 119.0, 84.0, 122.5])
        finally:
            await runtime.stop()


@asynccontextmanager
async def robotics_server(tmp_path: Path, manufacturer: str) -> AsyncIterator[tuple[str, list]]:
    """An asyncua server (not the mock) with the official Robotics model and names of its own:
    one MotionDeviceSystem "Cell 7", one six-axis MotionDevice whose positions are radians,
    written at 50 Hz (``values`` holds the last written, by NodeId)."""
    server = Server()
    await server.init()
    for name in (
        "Opc.Ua.Di.NodeSet2.xml",
        "Opc.Ua.IA.NodeSet2.xml",
        "Opc.Ua.Robotics.NodeSet2.xml",
    ):
        await server.import_xml(str(NODESETS_DIR / name))
    namespaces = await server.get_namespace_array()
    di, robotics = (
        namespaces.index(f"http://opcfoundation.org/UA/{m}/") for m in ("DI", "Robotics")
    )
    acme = await server.register_namespace(ACME)
    device_set = server.get_node(ua.NodeId(5001, di))
    system = await device_set.add_object(
        acme, "Cell 7", objecttype=ua.NodeId(1002, robotics), instantiate_optional=False
    )
    devices = await system.get_child(f"{robotics}:MotionDevices")
    device = await devices.add_object(
        acme, "KR6 #1", objecttype=ua.NodeId(1004, robotics), instantiate_optional=False
    )
    await (await device.get_child(f"{di}:Manufacturer")).write_value(ua.LocalizedText(manufacturer))
    await (await device.get_child(f"{di}:Model")).write_value(ua.LocalizedText("KR 6 R900 sixx"))
    await (await device.get_child(f"{di}:SerialNumber")).write_value("9000123")
    axes = await device.get_child(f"{robotics}:Axes")
    positions = []
    for i in range(1, 7):
        axis = await axes.add_object(
            acme, f"A{i}", objecttype=ua.NodeId(16601, robotics), instantiate_optional=False
        )
        position = await (await axis.get_child(f"{di}:ParameterSet")).get_child(
            f"{robotics}:ActualPosition"
        )
        units = ua.EUInformation(
            NamespaceUri=UNECE, UnitId=RADIAN, DisplayName=ua.LocalizedText("rad")
        )
        await (await position.get_child("0:EngineeringUnits")).write_value(units)
        positions.append(position.nodeid)
    server.set_endpoint(f"opc.tcp://127.0.0.1:{free_port()}")
    server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
    written: list[dict[ua.NodeId, float]] = []

    async def move() -> None:
        while True:
            t = dt.datetime.now(dt.UTC)
            step = {node: 0.5 * math.sin(t.timestamp() + i) for i, node in enumerate(positions)}
            for node, value in step.items():
                variant = ua.Variant(value, ua.VariantType.Double)
                await server.write_attribute_value(node, ua.DataValue(variant, SourceTimestamp=t))
            written.append(step)
            del written[:-500]
            await asyncio.sleep(0.02)

    await server.start()
    task = asyncio.create_task(move())
    try:
        yield server.endpoint.geturl(), written
    finally:
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)
        await server.stop()


async def test_a_robotics_server_with_its_own_names_is_discovered_and_followed(
    tmp_path: Path,
) -> None:
    async with robotics_server(tmp_path, HOSTILE) as (url, written):
        output = tmp_path / "cell7.toml"
        code, out, err = await discover(url, "-o", str(output), "--source", "cell7", cwd=tmp_path)
        assert code == 0, err
        text = output.read_text()
        raw = tomllib.loads(text)
        # The maker's name is a comment on one line: it added no key and no source.
        assert [s["name"] for s in raw["source"]] == ["cell7"]
        assert "allow_commands" not in raw["source"][0]
        assert "\\nallow_commands = true" in text
        # Nor does its ANSI escape reach the terminal or the file: shown as text.
        assert "\x1b" not in out + text and "\\x1b[2J" in out
        cell = load_cell(output, env={}, cache_dir=tmp_path / "cache")
        (robot,) = cell.robots
        assert robot.name == "KR6_1" and robot.family == "axis_group" and len(robot.joints) == 6
        assert all(j.node.startswith(f"nsu={ACME};i=") for j in robot.joints)
        runtime, health = await streamed(cell, "KR6_1")
        try:
            values = health.robots["KR6_1"].values
            assert values is not None
            # Radians on the server, degrees in the cell (no unit: the node's EngineeringUnits).
            sent = [np.degrees(list(step.values())) for step in written]
            assert any(np.allclose(values, step, atol=1e-9) for step in sent)
        finally:
            await runtime.stop()


@asynccontextmanager
async def plain_server() -> AsyncIterator[tuple[str, Callable[[], dict[str, float]]]]:
    """An asyncua server without the Robotics model: a folder ``ns=2;s=Robots`` of numbers."""
    server = Server()
    await server.init()
    idx = await server.register_namespace("urn:plant:plc")
    robots = await server.nodes.objects.add_folder(ua.NodeId("Robots", idx), "Robots")
    axis = await robots.add_object(ua.NodeId("Robots.Lift", idx), "Lift")
    made = {
        "Height": await axis.add_variable(ua.NodeId("Robots.Lift.Height", idx), "Height", 0.0),
        "Turn": await axis.add_variable(ua.NodeId("Robots.Lift.Turn", idx), "Turn", 0.0),
    }
    await axis.add_variable(ua.NodeId("Robots.Lift.Label", idx), "Label", "lift 1")
    for name, code, text in (("Height", MILLIMETRE, "mm"), ("Turn", DEGREE, "°")):
        info = ua.EUInformation(NamespaceUri=UNECE, UnitId=code, DisplayName=ua.LocalizedText(text))
        await made[name].add_property(ua.NodeId(NamespaceIndex=idx), "EngineeringUnits", info)
    server.set_endpoint(f"opc.tcp://127.0.0.1:{free_port()}")
    server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
    await server.start()
    await made["Height"].write_value(250.0)
    await made["Turn"].write_value(30.0)
    try:
        yield server.endpoint.geturl(), lambda: {"Height": 250.0, "Turn": 30.0}
    finally:
        await server.stop()


async def test_under_a_folder_of_a_server_without_robotics_writes_a_cell_that_streams(
    tmp_path: Path,
) -> None:
    async with plain_server() as (url, now):
        output = tmp_path / "plc.toml"
        code, out, err = await discover(
            url, "--under", "ns=2;s=Robots", "-o", str(output), cwd=tmp_path
        )
        assert code == 0, err
        cell = load_cell(output, env={}, cache_dir=tmp_path / "cache")
        (robot,) = cell.robots  # the object holding the numbers; the string is left out
        assert [j.node for j in robot.joints] == [
            "nsu=urn:plant:plc;s=Robots.Lift.Height",
            "nsu=urn:plant:plc;s=Robots.Lift.Turn",
        ]
        assert [j.si_unit for j in robot.joints] == ["m", "rad"]  # linear by its millimetres
        runtime, health = await streamed(cell, robot.name)
        try:
            values = health.robots[robot.name].values
            assert values is not None
            np.testing.assert_allclose(values, list(now().values()))
        finally:
            await runtime.stop()
    code, _, err = await discover(url, "-o", str(tmp_path / "none.toml"), cwd=tmp_path)
    assert code == 1 and "connection refused" in err
