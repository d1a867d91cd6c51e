"""What an OPC UA server holds of the Robotics specification (OPC 40010-1), or under a folder.

Robotics: every ``MotionDeviceSystemType`` instance (or of a subtype) within a
few levels of the Objects folder (the specification puts them in DI's
``DeviceSet``), its ``MotionDevices`` with DI's identification (Manufacturer,
Model, SerialNumber), and each device's ``Axes``: the NodeId of
``ParameterSet/ActualPosition`` with its EngineeringUnits, EURange and value,
and the axis's ``MotionProfile``. Types are matched by NodeId in the Robotics
namespace (with their subtypes), instances by what they are, not by name.

Under a folder (``--under``): the numeric variables found below it, grouped by
the object holding them.

Everything read is bounded (depth, nodes, axes): a hostile or huge server costs
a bounded number of requests, and what is left out is noted.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from asyncua import ua
from asyncua.client.client import Client
from asyncua.common.node import Node
from asyncua.ua.object_ids import ObjectIds
from asyncua.ua.uaerrors import UaStatusCodeError

from ...opcua import node_id_key
from ...opcua.units import KnownUnit, describe, unit_of
from ...text import printable

DI_URI = "http://opcfoundation.org/UA/DI/"
ROBOTICS_URI = "http://opcfoundation.org/UA/Robotics/"
MOTION_DEVICE_SYSTEM_TYPE = 1002
MOTION_DEVICE_TYPE = 1004
AXIS_TYPE = 16601
SEARCH_DEPTH = 4
"""How deep below the Objects folder MotionDeviceSystems are looked for."""
MAX_VISITED = 2000
"""Nodes browsed at most while looking (the server's own ``Server`` object is skipped)."""
MAX_AXES = 32
MAX_DEVICES = 64
NUMERIC = {
    ObjectIds.Double, ObjectIds.Float, ObjectIds.Int16, ObjectIds.Int32, ObjectIds.Int64,
    ObjectIds.UInt16, ObjectIds.UInt32, ObjectIds.UInt64, ObjectIds.SByte, ObjectIds.Byte,
}  # fmt: skip


@dataclass
class Axis:
    """One joint's position node as the server describes it."""

    name: str
    node: str
    """Its node key (``nsu=...``)."""
    unit: KnownUnit | None
    unit_text: str | None
    """The EngineeringUnits as the server gave them (for a unit linkview does not convert)."""
    limits: tuple[float, float] | None
    """EURange (in the node's unit)."""
    value: float | None
    linear: bool | None
    """From MotionProfile (LINEAR/LINEAR_ENDLESS), else from the unit; None: unknown."""


@dataclass
class Device:
    """A MotionDevice (or, under a folder, an object holding numeric variables)."""

    name: str
    manufacturer: str | None = None
    model: str | None = None
    serial: str | None = None
    axes: list[Axis] = field(default_factory=list)


@dataclass
class Found:
    """What a server holds, and what was not read."""

    url: str
    systems: dict[str, list[Device]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


async def robotics(client: Client, url: str) -> Found:
    """Every MotionDeviceSystem with its devices and axes (``Found.notes``: what was not)."""
    found = Found(url)
    namespaces = await client.get_namespace_array()
    if ROBOTICS_URI not in namespaces:
        found.notes.append(
            "the server has no Robotics namespace: give --under with the folder of the positions"
        )
        return found
    space = _Space(client, namespaces)
    systems = await space.instances(MOTION_DEVICE_SYSTEM_TYPE, found)
    devices_types = await space.subtypes(MOTION_DEVICE_TYPE)
    for system in systems:
        name = printable((await system.read_browse_name()).Name or "?")
        devices = []
        folder = await space.child(system, ROBOTICS_URI, "MotionDevices")
        listed = [] if folder is None else await space.children(folder, devices_types)
        if len(listed) > MAX_DEVICES:
            found.notes.append(f"{name}: {len(listed)} motion devices; the first {MAX_DEVICES}")
        for node, browse_name in listed[:MAX_DEVICES]:
            try:
                devices.append(await space.device(node, browse_name, found))
            except UaStatusCodeError as exc:  # one device that cannot be read spoils only itself
                found.notes.append(f"{name}/{browse_name}: {type(exc).__name__}")
        found.systems[name] = devices
    return found


async def under(client: Client, url: str, folder: str) -> Found:
    """The numeric variables below ``folder`` (a NodeId), by the object holding each."""
    found = Found(url)
    space = _Space(client, await client.get_namespace_array())
    root = client.get_node(folder)
    try:
        name = printable((await root.read_browse_name()).Name or folder)
    except UaStatusCodeError as exc:
        found.notes.append(f"{folder}: {type(exc).__name__}")
        return found
    groups: dict[str, Device] = {}
    queue: list[tuple[Node, str, int]] = [(root, name, 0)]
    visited = 0
    while queue and visited < MAX_VISITED:
        node, label, depth = queue.pop(0)
        visited += 1
        for child in await node.get_children_descriptions():
            child_node = client.get_node(child.NodeId)
            child_name = printable(child.BrowseName.Name or "?")
            if child.NodeClass == ua.NodeClass.Variable:
                axis = await space.axis_at(child_node, child_name, numeric_only=True)
                if axis is not None:
                    group = groups.setdefault(label, Device(label))
                    if len(group.axes) < MAX_AXES:
                        group.axes.append(axis)
            elif child.NodeClass == ua.NodeClass.Object and depth < SEARCH_DEPTH:
                queue.append((child_node, child_name, depth + 1))
    if queue:
        found.notes.append(f"{name}: more than {MAX_VISITED} nodes; the first {MAX_VISITED}")
    found.systems[name] = list(groups.values())
    return found


class _Space:
    """Reading one server: its namespaces, types and nodes."""

    def __init__(self, client: Client, namespaces: list[str]) -> None:
        self.client = client
        self.namespaces = namespaces
        self.robotics = namespaces.index(ROBOTICS_URI) if ROBOTICS_URI in namespaces else -1
        self.di = namespaces.index(DI_URI) if DI_URI in namespaces else -1

    def key(self, node: ua.NodeId) -> str:
        return node_id_key(node, self.namespaces[node.NamespaceIndex])

    async def subtypes(self, number: int) -> set[ua.NodeId]:
        """A Robotics type and every subtype of it the server has."""
        found = {ua.NodeId(ua.Int32(number), ua.Int16(self.robotics))}
        todo = list(found)
        while todo and len(found) < 1000:
            node = self.client.get_node(todo.pop())
            for ref in await node.get_children_descriptions(refs=ObjectIds.HasSubtype):
                if ref.NodeId not in found:
                    found.add(ref.NodeId)
                    todo.append(ref.NodeId)
        return found

    async def instances(self, number: int, found: Found) -> list[Node]:
        """Objects of the type (or a subtype) within SEARCH_DEPTH of the Objects folder."""
        types = await self.subtypes(number)
        skip = ua.NodeId(ua.Int32(ObjectIds.Server))
        result: list[Node] = []
        queue: list[tuple[Node, int]] = [(self.client.nodes.objects, 0)]
        visited = 0
        while queue and visited < MAX_VISITED:
            node, depth = queue.pop(0)
            visited += 1
            refs = await node.get_children_descriptions(nodeclassmask=ua.NodeClass.Object)
            for ref in refs:
                if ref.NodeId == skip:
                    continue
                child = self.client.get_node(ref.NodeId)
                if ref.TypeDefinition in types:
                    result.append(child)
                elif depth + 1 < SEARCH_DEPTH:
                    queue.append((child, depth + 1))
        if queue:
            found.notes.append(f"looked at the first {MAX_VISITED} objects only")
        return result

    async def child(self, node: Node, uri: str, name: str) -> Node | None:
        """The child called ``name`` in namespace ``uri``, if there is one."""
        if uri not in self.namespaces:
            return None
        try:
            return await node.get_child(ua.QualifiedName(name, self.namespaces.index(uri)))
        except UaStatusCodeError:
            return None

    async def children(self, node: Node, types: set[ua.NodeId]) -> list[tuple[Node, str]]:
        """Object children of one of ``types``, with their browse names."""
        refs = await node.get_children_descriptions(nodeclassmask=ua.NodeClass.Object)
        # ``<AxisIdentifier>`` and the like name a type's placeholders; a server that copied
        # them with the type (asyncua does) has no such device or axis.
        return [
            (self.client.get_node(r.NodeId), printable(r.BrowseName.Name or "?"))
            for r in refs
            if r.TypeDefinition in types and not _placeholder(r.BrowseName.Name or "")
        ]

    async def text(self, node: Node, uri: str, name: str) -> str | None:
        """A property's value as text (LocalizedText's text), None where it has none."""
        prop = await self.child(node, uri, name)
        if prop is None:
            return None
        try:
            value = await prop.read_value()
        except UaStatusCodeError:
            return None
        value = value.Text if isinstance(value, ua.LocalizedText) else value
        return None if value is None else printable(str(value))

    async def device(self, node: Node, name: str, found: Found) -> Device:
        """A MotionDevice: its identification and axes."""
        device = Device(
            name,
            await self.text(node, DI_URI, "Manufacturer"),
            await self.text(node, DI_URI, "Model"),
            await self.text(node, DI_URI, "SerialNumber"),
        )
        axes_folder = await self.child(node, ROBOTICS_URI, "Axes")
        listed = (
            []
            if axes_folder is None
            else await self.children(axes_folder, await self.subtypes(AXIS_TYPE))
        )
        if len(listed) > MAX_AXES:
            found.notes.append(f"{name}: {len(listed)} axes; the first {MAX_AXES}")
        for axis_node, axis_name in listed[:MAX_AXES]:
            parameters = await self.child(axis_node, DI_URI, "ParameterSet")
            position = (
                None
                if parameters is None
                else await self.child(parameters, ROBOTICS_URI, "ActualPosition")
            )
            if position is None:
                found.notes.append(f"{name}/{axis_name}: no ParameterSet/ActualPosition")
                continue
            axis = await self.axis_at(position, axis_name)
            if axis is not None:
                profile = await self.child(axis_node, ROBOTICS_URI, "MotionProfile")
                axis.linear = await _linear(profile, axis.linear)
                device.axes.append(axis)
        return device

    async def axis_at(self, node: Node, name: str, numeric_only: bool = False) -> Axis | None:
        """A position variable: its key, unit, range and value (None: not a number)."""
        if numeric_only:
            data_type = await node.read_data_type()
            if data_type.NamespaceIndex != 0 or data_type.Identifier not in NUMERIC:
                return None
        info = await _property(node, "EngineeringUnits")
        limits = await _property(node, "EURange")
        try:
            value: Any = await node.read_value()
        except UaStatusCodeError:
            value = None
        unit = unit_of(info) if isinstance(info, ua.EUInformation) else None
        return Axis(
            name,
            self.key(node.nodeid),
            unit,
            describe(info) if isinstance(info, ua.EUInformation) else None,
            (float(limits.Low), float(limits.High)) if isinstance(limits, ua.Range) else None,
            float(value)
            if isinstance(value, int | float) and not isinstance(value, bool)
            else None,
            None if unit is None else unit.cell_unit in ("mm", "m"),
        )


def _placeholder(name: str) -> bool:
    return name.startswith("<") and name.endswith(">")


async def _property(node: Node, name: str) -> Any:
    try:
        return await (await node.get_child(ua.QualifiedName(name, 0))).read_value()
    except UaStatusCodeError:
        return None


async def _linear(profile: Node | None, default: bool | None) -> bool | None:
    """AxisMotionProfileEnumeration: 1, 2 rotary; 3, 4 linear; else what the unit says."""
    if profile is None:
        return default
    try:
        value = await profile.read_value()
    except UaStatusCodeError:
        return default
    if not isinstance(value, int) or isinstance(value, bool):
        return default
    return {1: False, 2: False, 3: True, 4: True}.get(value, default)
