"""The mock OPC UA server, read by asyncua's own client: the official models, robots, units."""

from __future__ import annotations

from pathlib import Path

import pytest
from asyncua import Client, ua

from server.mock_opcua import COMPANIONS, ROBOTICS_URI, companion_server
from server.mock_opcua.address_space import NODESETS_DIR, shelf_folder
from tests.opcua.helpers import actual, running

DI_URI = "http://opcfoundation.org/UA/DI/"
# From the OPC Foundation's UNECE_to_OPCUA.csv (UA-Nodeset, Schema/).
DEGREE = 17476
UNECE = "http://www.opcfoundation.org/UA/units/un/cefact"


def test_the_nodesets_are_the_opc_foundations_with_their_licence() -> None:
    for name, uri in zip(
        ("Opc.Ua.Di.NodeSet2.xml", "Opc.Ua.IA.NodeSet2.xml", "Opc.Ua.Robotics.NodeSet2.xml"),
        COMPANIONS,
        strict=True,
    ):
        text = (NODESETS_DIR / name).read_text(encoding="utf-8")
        assert "OPC Foundation MIT License 1.00" in text
        assert f'<Model ModelUri="{uri}"' in text
    assert "OPC Foundation MIT License 1.00" in (NODESETS_DIR / "LICENSE.txt").read_text()


async def test_an_address_space_from_the_cache_is_the_one_built_from_the_files(
    tmp_path: Path,
) -> None:
    built = await companion_server(tmp_path)
    assert (shelf_folder(tmp_path) / "complete").is_file()
    cached = await companion_server(tmp_path)
    for server in (built, cached):
        namespaces = await server.get_namespace_array()
        assert namespaces[2:5] == list(COMPANIONS)
        robotics = namespaces.index(ROBOTICS_URI)
        kind = server.get_node(ua.NodeId(1004, robotics))
        assert (await kind.read_browse_name()).Name == "MotionDeviceType"


async def test_the_demo_robots_are_robotics_motion_devices(opcua_cache: Path) -> None:
    async with running(opcua_cache) as mock, Client(mock.url) as client:
        namespaces = await client.get_namespace_array()
        di, robotics = namespaces.index(DI_URI), namespaces.index(ROBOTICS_URI)
        device_set = client.get_node(ua.NodeId(5001, di))
        kinds = {c: await c.read_type_definition() for c in await device_set.get_children()}
        (system,) = [c for c, kind in kinds.items() if kind == ua.NodeId(1002, robotics)]
        devices = await system.get_child(f"{robotics}:MotionDevices")
        by_name = {(await d.read_browse_name()).Name: d for d in await devices.get_children()}
        assert sorted(by_name) == ["iiwa", "kin12", "pos"]
        iiwa = by_name["iiwa"]
        assert await iiwa.read_type_definition() == ua.NodeId(1004, robotics)
        maker = await (await iiwa.get_child(f"{di}:Manufacturer")).read_value()
        model = await (await iiwa.get_child(f"{di}:Model")).read_value()
        serial = await (await iiwa.get_child(f"{di}:SerialNumber")).read_value()
        assert (maker.Text, model.Text) == ("KUKA", "LBR iiwa 7 R800") and serial.startswith("LV-")
        axes = await iiwa.get_child(f"{robotics}:Axes")
        names = [(await a.read_browse_name()).Name for a in await axes.get_children()]
        assert names == [f"iiwa_a{i}" for i in range(1, 8)]
        for axis in await axes.get_children():
            assert await axis.read_type_definition() == ua.NodeId(16601, robotics)  # AxisType


async def test_an_axis_has_its_unit_range_and_profile(opcua_cache: Path) -> None:
    async with running(opcua_cache) as mock, Client(mock.url) as client:
        namespaces = await client.get_namespace_array()
        node = client.get_node(_node_id(actual("iiwa", "iiwa_a1"), namespaces))
        units = await (await node.get_child("0:EngineeringUnits")).read_value()
        limits = await (await node.get_child("0:EURange")).read_value()
        axis = await (await node.get_parent()).get_parent()
        robotics = namespaces.index(ROBOTICS_URI)
        profile = await (await axis.get_child(f"{robotics}:MotionProfile")).read_value()
        turn = client.get_node(_node_id(actual("pos", "pos_turn"), namespaces))
        turn_axis = await (await turn.get_parent()).get_parent()
        endless = await (await turn_axis.get_child(f"{robotics}:MotionProfile")).read_value()
        value = await node.read_value()
    assert (units.NamespaceUri, units.UnitId) == (UNECE, DEGREE)
    # The demo arm's axis 1 moves within 70 % of the iiwa's 170 degrees.
    assert (limits.Low, limits.High) == pytest.approx((-119.0, 119.0))
    assert (profile, endless) == (1, 2)  # ROTARY; the turntable without limits: ROTARY_ENDLESS
    assert isinstance(value, float) and -119.0 <= value <= 119.0


def _node_id(key: str, namespaces: list[str]) -> ua.NodeId:
    """An ``nsu=`` key as a NodeId of this server (asyncua's parser, its index looked up)."""
    uri, rest = key.removeprefix("nsu=").split(";", 1)
    return ua.NodeId.from_string(f"ns={namespaces.index(uri)};{rest}")
