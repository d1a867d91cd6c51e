"""Node keys to NodeIds in one session, and each node's unit from its EngineeringUnits.

Everything is asked in as few requests as the server allows: the namespace
array once, every browse path in one TranslateBrowsePathsToNodeIds, every
node's ``EngineeringUnits`` property in one more and their values in one Read.
A key that cannot be resolved spoils only its own value (``Resolved.errors``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from asyncua import ua
from asyncua.client.client import Client
from asyncua.ua.attribute_ids import AttributeIds
from asyncua.ua.object_ids import ObjectIds

from ..sources import SourceError
from .nodes import BrowsePathKey, NodeIdKey, parse_node
from .units import describe, factor, unit_of

OBJECTS = ua.NodeId(ua.Int32(ObjectIds.ObjectsFolder))
HIERARCHICAL = ua.NodeId(ua.Int32(ObjectIds.HierarchicalReferences))
HAS_PROPERTY = ua.NodeId(ua.Int32(ObjectIds.HasProperty))


@dataclass(frozen=True)
class UnitRule:
    """What unit a node's values must be delivered in (the joint's, as the cell has it)."""

    cell_unit: str
    from_device: bool
    """True where the cell left the unit out: the node's EngineeringUnits are converted."""


@dataclass
class Resolved:
    """The followed nodes as this session knows them."""

    ids: dict[str, ua.NodeId] = field(default_factory=dict)
    factors: dict[str, float] = field(default_factory=dict)
    """Node value x factor = value in the joint's unit (1.0 where the cell's unit is taken)."""
    errors: dict[str, SourceError] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    """Caveats for health: a unit assumed, a cell unit that overrides the node's."""


async def resolve(client: Client, keys: list[str], units: Mapping[str, UnitRule]) -> Resolved:
    """Each key's NodeId and unit factor, or why it has none."""
    resolved = Resolved()
    namespaces = await client.get_namespace_array()
    paths: dict[str, ua.BrowsePath] = {}
    for key in keys:
        try:
            node = parse_node(key)
            if isinstance(node, NodeIdKey):
                resolved.ids[key] = _node_id(node, namespaces)
            else:
                paths[key] = _browse_path(OBJECTS, node, namespaces)
        except (ValueError, SourceError) as exc:
            resolved.errors[key] = SourceError(f"{key}: {exc}")
    if paths:
        await _translate(client, paths, resolved, namespaces)
    await _units(client, resolved, units)
    return resolved


def _node_id(key: NodeIdKey, namespaces: list[str]) -> ua.NodeId:
    if key.uri is None:
        return key.node
    return ua.NodeId(
        key.node.Identifier, ua.Int16(_index(key.uri, namespaces)), key.node.NodeIdType
    )


def _index(uri: str, namespaces: list[str]) -> int:
    try:
        return namespaces.index(uri)
    except ValueError:
        raise SourceError(f"the server has no namespace {uri!r}") from None


def _browse_path(start: ua.NodeId, key: BrowsePathKey, namespaces: list[str]) -> ua.BrowsePath:
    elements = [
        ua.RelativePathElement(
            ReferenceTypeId=HIERARCHICAL,
            IsInverse=False,  # type: ignore[arg-type]  # asyncua: Boolean is a placeholder class
            IncludeSubtypes=True,  # type: ignore[arg-type]
            TargetName=ua.QualifiedName(ua.String(name), ua.UInt16(_index(uri, namespaces))),
        )
        for uri, name in key.names
    ]
    return ua.BrowsePath(StartingNode=start, RelativePath=ua.RelativePath(Elements=elements))


async def _translate(
    client: Client, paths: dict[str, ua.BrowsePath], resolved: Resolved, namespaces: list[str]
) -> None:
    results = await client.uaclient.translate_browsepaths_to_nodeids(list(paths.values()))
    failed: dict[str, BrowsePathKey] = {}
    for (key, _), result in zip(paths.items(), results, strict=True):
        if result.StatusCode.is_good() and result.Targets:
            resolved.ids[key] = result.Targets[0].TargetId
        else:
            failed[key] = parse_node(key)  # type: ignore[assignment]
            resolved.errors[key] = SourceError(f"{key}: {result.StatusCode.name}")
    for key, path in failed.items():
        resolved.errors[key] = SourceError(
            f"{key}: {await _first_missing(client, path, namespaces)}"
        )


async def _first_missing(client: Client, path: BrowsePathKey, namespaces: list[str]) -> str:
    """Which name of a browse path that was not found is the first missing one."""
    prefixes = [BrowsePathKey(path.names[:n]) for n in range(1, len(path.names) + 1)]
    requests = [_browse_path(OBJECTS, p, namespaces) for p in prefixes]
    results = await client.uaclient.translate_browsepaths_to_nodeids(requests)
    for n, result in enumerate(results):
        if not (result.StatusCode.is_good() and result.Targets):
            under = path.text(n) or "the Objects folder"
            missing = BrowsePathKey(path.names[n : n + 1]).text()
            return f"BadNoMatch: no {missing!r} under {under}"
    return "BadNoMatch: the path's last node is not a variable"


async def _units(client: Client, resolved: Resolved, rules: Mapping[str, UnitRule]) -> None:
    """Factors from each node's EngineeringUnits, where its joint's unit comes from the device."""
    resolved.factors = dict.fromkeys(resolved.ids, 1.0)
    keys = [k for k in resolved.ids if k in rules]
    if not keys:
        return
    eu = ua.RelativePathElement(
        ReferenceTypeId=HAS_PROPERTY,
        IsInverse=False,  # type: ignore[arg-type]  # asyncua: Boolean is a placeholder class
        IncludeSubtypes=True,  # type: ignore[arg-type]
        TargetName=ua.QualifiedName(ua.String("EngineeringUnits"), ua.UInt16(0)),
    )
    paths = [
        ua.BrowsePath(StartingNode=resolved.ids[k], RelativePath=ua.RelativePath(Elements=[eu]))
        for k in keys
    ]
    found = await client.uaclient.translate_browsepaths_to_nodeids(paths)
    with_eu = [(k, r.Targets[0].TargetId) for k, r in zip(keys, found, strict=True) if r.Targets]
    infos: dict[str, ua.EUInformation] = {}
    if with_eu:
        values = await client.uaclient.read_attributes(
            [node for _, node in with_eu], AttributeIds.Value
        )
        for (key, _), value in zip(with_eu, values, strict=True):
            body = value.Value.Value if value.Value is not None else None
            if isinstance(body, ua.EUInformation):
                infos[key] = body
    for key in keys:
        _unit_factor(key, rules[key], infos.get(key), resolved)


def _unit_factor(key: str, rule: UnitRule, info: ua.EUInformation | None, out: Resolved) -> None:
    unit = None if info is None else unit_of(info)
    if not rule.from_device:  # the cell's unit wins; a disagreement is worth a note
        if unit is not None and (unit.cell_unit, unit.factor) != (rule.cell_unit, 1.0):
            out.notes.append(
                f"{key} says its values are in {unit.name}s; the cell's {rule.cell_unit} is used"
            )
        return
    if info is None:
        out.notes.append(f"{key} has no EngineeringUnits: its values are taken as {rule.cell_unit}")
        return
    try:
        if unit is None:
            raise ValueError(
                f"its unit {describe(info)} is not one linkview converts: "
                "give the joint's unit in the cell"
            )
        out.factors[key] = factor(unit, rule.cell_unit)
    except ValueError as exc:
        del out.ids[key]
        out.errors[key] = SourceError(f"{key}: {exc}")
