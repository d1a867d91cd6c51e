"""The mock's robots as the OPC UA Robotics specification (OPC 40010-1) lays them out.

``Objects/DeviceSet`` (DI) holds one ``MotionDeviceSystemType`` instance; its
``MotionDevices`` folder one ``MotionDeviceType`` per axis group of the simulated
machine (identification from DI: Manufacturer, Model, ProductCode, SerialNumber),
its ``Axes`` one ``AxisType`` per axis, whose ``ParameterSet`` (DI) holds
``ActualPosition`` (Robotics), an ``AnalogUnitType`` with ``EngineeringUnits``
(UNECE) and, where the axis has limits, ``EURange``. Instances get string
NodeIds in the mock's namespace that spell their path
(``iiwa.Axes.iiwa_a1.ParameterSet.ActualPosition``), as asyncua's instantiation
does. An axis whose node the cell names (an embedded mock) serves it at that
NodeId (its namespace registered by URI), or at that browse path.

Each MotionDevice also has ``MoveJoints`` (the mock's own namespace: Robotics
defines no motion commands), taking the axes' targets as one Double array.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field
from typing import Any

from asyncua import ua
from asyncua.common.instantiate_util import instantiate
from asyncua.common.node import Node
from asyncua.server.server import Server
from asyncua.ua.attribute_ids import AttributeIds
from asyncua.ua.object_ids import ObjectIds
from asyncua.ua.status_codes import StatusCodes
from asyncua.ua.uaerrors import UaStatusCodeError

from ..mock_ctrlx import AxisGroup, Machine, SimAxis
from ..mock_ctrlx.machine import IIWA_TRAFO, TYPE12_TRAFO
from ..opcua.nodes import OPC_UA_URI, BrowsePathKey, NodeIdKey, parse_node
from ..opcua.units import eu_information
from .address_space import DI_URI, ROBOTICS_URI

MOCK_URI = "urn:linkview:mock-opcua"
"""The namespace of the mock's instances (and of its MoveJoints methods)."""
SYSTEM = "linkview-mock"
ANALOG_UNIT_TYPE = ua.NodeId(ua.Int32(ObjectIds.AnalogUnitType))
# Robotics' NodeIds in its own namespace (OPC 40010-1, NodeIds.csv).
MOTION_DEVICE_SYSTEM_TYPE = 1002
MOTION_DEVICE_TYPE = 1004
AXIS_TYPE = 16601
DEVICE_SET = 5001  # DI
MOTION_PROFILE = {"deg": 1, "rad": 1, "mm": 3, "m": 3}
"""AxisMotionProfileEnumeration: ROTARY, LINEAR (the ``_ENDLESS`` ones where unlimited)."""


@dataclass(frozen=True)
class Identity:
    """What a MotionDevice says of itself (DI's nameplate, Robotics' category)."""

    manufacturer: str
    model: str
    category: int
    """MotionDeviceCategoryEnumeration: 0 OTHER, 1 ARTICULATED_ROBOT, 5 PARALLEL_ROBOT, ..."""


KNOWN = {
    TYPE12_TRAFO.name: Identity("Bosch Rexroth", "IndraMotion MLC kinematic Type 12", 5),
    IIWA_TRAFO.name: Identity("KUKA", "LBR iiwa 7 R800", 1),
}


def identity(group: AxisGroup) -> Identity:
    """The demo robots' makers where the group's kinematics tells, else the mock's own."""
    if group.kinematics is not None and group.kinematics.name in KNOWN:
        return KNOWN[group.kinematics.name]
    return Identity("linkview", f"simulated {group.name}", 0)


def serial_number(group: AxisGroup) -> str:
    """A stable serial number per group name."""
    return f"LV-{zlib.crc32(group.name.encode()):08X}"


@dataclass
class Served:
    """The variables written each cycle: per node, its group, axis index, and setpoint or not."""

    values: list[tuple[ua.NodeId, str, int, bool]] = field(default_factory=list)
    methods: dict[str, ua.NodeId] = field(default_factory=dict)
    """MoveJoints of each group."""


async def build_robots(server: Server, machine: Machine, system: str = SYSTEM) -> Served:
    """Add the machine's groups to ``server`` as a Robotics MotionDeviceSystem."""
    space = _Space(server, await server.register_namespace(MOCK_URI))
    await space.load()
    device_set = server.get_node(ua.NodeId(ua.Int32(DEVICE_SET), ua.Int16(space.di)))
    system_node = await device_set.add_object(
        space.mock_id(system),
        ua.QualifiedName(system, space.mock),
        objecttype=space.robotics_id(MOTION_DEVICE_SYSTEM_TYPE),
        instantiate_optional=False,
    )
    devices = await system_node.get_child(space.robotics_name("MotionDevices"))
    served = Served()
    for group in machine.groups.values():
        await _device(space, devices, group, machine, served)
    await _drop_placeholders(system_node)
    return served


async def _drop_placeholders(node: Node) -> None:
    """Remove what asyncua instantiated of the types' mandatory placeholders.

    ``<MotionDeviceIdentifier>``, ``<AxisIdentifier>``, ... stand for the instances a
    server adds (as the mock does); asyncua copies them as if they were nodes.
    """
    for child in await node.get_children():
        name = (await child.read_browse_name()).Name or ""
        if name.startswith("<") and name.endswith(">"):
            await child.delete(recursive=True)
        elif (await child.read_node_class()) == ua.NodeClass.Object:
            await _drop_placeholders(child)


class _Space:
    """Namespace indices of the server, and NodeIds and names in them."""

    def __init__(self, server: Server, mock: int) -> None:
        self.server = server
        self.mock = mock
        self.di = self.robotics = 0

    async def load(self) -> None:
        self.di = await self.server.get_namespace_index(DI_URI)
        self.robotics = await self.server.get_namespace_index(ROBOTICS_URI)

    def mock_id(self, text: str) -> ua.NodeId:
        return ua.NodeId(ua.String(text), ua.Int16(self.mock))

    def robotics_id(self, number: int) -> ua.NodeId:
        return ua.NodeId(ua.Int32(number), ua.Int16(self.robotics))

    def robotics_name(self, name: str) -> ua.QualifiedName:
        return ua.QualifiedName(ua.String(name), ua.UInt16(self.robotics))

    def di_name(self, name: str) -> ua.QualifiedName:
        return ua.QualifiedName(ua.String(name), ua.UInt16(self.di))


async def _device(
    space: _Space, devices: Node, group: AxisGroup, machine: Machine, served: Served
) -> None:
    device = await devices.add_object(
        space.mock_id(group.name),
        ua.QualifiedName(group.name, space.mock),
        objecttype=space.robotics_id(MOTION_DEVICE_TYPE),
        instantiate_optional=False,
    )
    who = identity(group)
    await _set(device, space.di_name("Manufacturer"), ua.LocalizedText(who.manufacturer))
    await _set(device, space.di_name("Model"), ua.LocalizedText(who.model))
    await _set(device, space.di_name("ProductCode"), who.model)
    await _set(device, space.di_name("SerialNumber"), serial_number(group))
    category = await device.get_child(space.robotics_name("MotionDeviceCategory"))
    await category.write_value(ua.Variant(who.category, ua.VariantType.Int32))
    axes = await device.get_child(space.robotics_name("Axes"))
    for index, axis in enumerate(group.axes):
        await _axis(space, axes, group, index, axis, served)
    served.methods[group.name] = await _move_method(space, device, group, machine)


async def _axis(
    space: _Space, axes: Node, group: AxisGroup, index: int, axis: SimAxis, served: Served
) -> None:
    # An axis at a node the cell names is called after it: A1, A2, ... make better names.
    name = axis.name if axis.node is None else f"A{index + 1}"
    node = await axes.add_object(
        space.mock_id(f"{group.name}.Axes.{name}"),
        ua.QualifiedName(name, space.mock),
        objecttype=space.robotics_id(AXIS_TYPE),
        instantiate_optional=False,
    )
    endless = not (math.isfinite(axis.lo) and math.isfinite(axis.hi))
    profile = await node.get_child(space.robotics_name("MotionProfile"))
    await profile.write_value(ua.Variant(MOTION_PROFILE[axis.unit] + endless, ua.VariantType.Int32))
    parameters = await node.get_child(space.di_name("ParameterSet"))
    actual = await parameters.get_child(space.robotics_name("ActualPosition"))
    key = None if axis.node is None else parse_node(axis.node)
    if isinstance(key, NodeIdKey):  # the cell names the node: it is the ActualPosition
        await actual.delete(recursive=True)
        at = await _node_id(space.server, key)
        actual = await _analog(parameters, at, space.robotics_name("ActualPosition"), axis)
    else:
        await _describe(actual, axis)
    served.values.append((actual.nodeid, group.name, index, False))
    if isinstance(key, BrowsePathKey):  # the cell names a path: served there too
        at_path = await _path(space.server, key, axis)
        served.values.append((at_path.nodeid, group.name, index, False))
    if axis.setpoint_node is not None:
        setpoint = parse_node(axis.setpoint_node)
        if isinstance(setpoint, NodeIdKey):
            commanded_name = ua.QualifiedName("CommandedPosition", space.mock)
            node_id = await _node_id(space.server, setpoint)
            commanded = await _analog(parameters, node_id, commanded_name, axis)
        else:
            commanded = await _path(space.server, setpoint, axis)
        served.values.append((commanded.nodeid, group.name, index, True))


async def _set(parent: Node, name: ua.QualifiedName, value: Any) -> None:
    await (await parent.get_child(name)).write_value(value)


async def _node_id(server: Server, key: NodeIdKey) -> ua.NodeId:
    """``key``'s NodeId on this server (its namespace registered if the URI is new)."""
    if key.uri is None:
        return key.node
    index = await server.register_namespace(key.uri)
    return ua.NodeId(key.node.Identifier, ua.Int16(index), key.node.NodeIdType)


async def _analog(parent: Node, node_id: ua.NodeId, name: ua.QualifiedName, axis: SimAxis) -> Node:
    """An AnalogUnitType variable at ``node_id`` holding the axis's position."""
    kind = Node(parent.session, ANALOG_UNIT_TYPE)
    made = await instantiate(parent, kind, node_id, bname=name, instantiate_optional=False)
    node: Node = made[0]
    await _describe(node, axis)
    return node


async def _describe(node: Node, axis: SimAxis) -> None:
    """Type, unit and (where limited) range of a position variable."""
    double = ua.Variant(ua.NodeId(ua.Int32(ObjectIds.Double)), ua.VariantType.NodeId)
    await node.write_attribute(AttributeIds.DataType, ua.DataValue(double))
    await node.write_value(ua.Variant(0.0, ua.VariantType.Double))
    units = await node.get_child(ua.QualifiedName("EngineeringUnits", ua.UInt16(0)))
    await units.write_value(ua.Variant(eu_information(axis.unit), ua.VariantType.ExtensionObject))
    if math.isfinite(axis.lo) and math.isfinite(axis.hi):
        limits = ua.Variant(ua.Range(Low=axis.lo, High=axis.hi), ua.VariantType.ExtensionObject)
        name = ua.QualifiedName("EURange", ua.UInt16(0))
        try:
            await (await node.get_child(name)).write_value(limits)
        except UaStatusCodeError:  # optional in AnalogUnitType: added where not instantiated
            await node.add_property(
                ua.NodeId(NamespaceIndex=node.nodeid.NamespaceIndex),
                name,
                limits,
                ua.VariantType.ExtensionObject,
                ua.NodeId(ua.Int32(ObjectIds.Range)),
            )


async def _path(server: Server, key: BrowsePathKey, axis: SimAxis) -> Node:
    """The node at a browse path from Objects, made where missing (objects, then a variable)."""
    node = server.nodes.objects
    *folders, (uri, last) = key.names
    for uri_, name in folders:
        qname = ua.QualifiedName(name, await _index(server, uri_))
        try:
            node = await node.get_child(qname)
        except UaStatusCodeError:
            node = await node.add_object(ua.NodeId(NamespaceIndex=qname.NamespaceIndex), qname)
    qname = ua.QualifiedName(last, await _index(server, uri))
    variable: Node
    (variable, *_) = await instantiate(
        node,
        server.get_node(ANALOG_UNIT_TYPE),
        ua.NodeId(NamespaceIndex=qname.NamespaceIndex),
        bname=qname,
        instantiate_optional=False,
    )
    await _describe(variable, axis)
    return variable


async def _index(server: Server, uri: str) -> int:
    return 0 if uri == OPC_UA_URI else await server.register_namespace(uri)


async def _move_method(
    space: _Space, device: Node, group: AxisGroup, machine: Machine
) -> ua.NodeId:
    """``MoveJoints(Positions: Double[])``: a synchronised move of the group's axes."""

    async def move(parent: ua.NodeId, positions: ua.Variant) -> list[ua.Variant] | ua.StatusCode:
        try:
            machine.command(group.name, [float(v) for v in positions.Value])
        except (TypeError, ValueError):  # a wrong count, or a target out of an axis's range
            return ua.StatusCode(ua.UInt32(StatusCodes.BadOutOfRange))
        return []

    argument = ua.Argument(
        Name="Positions",
        DataType=ua.NodeId(ua.Int32(ObjectIds.Double)),
        ValueRank=1,
        ArrayDimensions=[ua.UInt32(len(group.axes))],
        Description=ua.LocalizedText("the axes' targets, in the axes' units"),
    )
    method = await device.add_method(
        space.mock_id(f"{group.name}.MoveJoints"),
        ua.QualifiedName("MoveJoints", space.mock),
        move,
        [argument],
        [],
    )
    return method.nodeid
