"""The mock data layer's node tree: read, browse, metadata, write, create and delete.

Nodes (``<axis>`` and ``<group>`` from the machine):

* each axis's position node, a double in the axis's unit: ``SimAxis.node`` when
  given, else ``motion/axs/<axis>/state/values/actual/pos``; its setpoint at
  ``SimAxis.setpoint_node`` where given. An axis at the default address also
  has ``motion/axs/<axis>/state/values/actual`` (object ``{actualPos,
  actualPosUnit}``), ``state/values/ipo/pos`` (the setpoint, which the actual
  position trails by the machine's lag) and ``state/values/ipo`` (``{ipoPos,
  ipoPosUnit}``), ``cfg/properties`` and ``cfg/lim``, ``cmd/pos-abs`` (write
  ``{"axsPos": x}`` or a number to move it) and ``cmd/reset``. Position nodes
  give their unit in their metadata;
* ``motion/state/axs-list``, ``motion/state/kin-list`` and, per group with a
  joint transformation, ``motion/kin/<group>/cfg`` (``_motion_nodes``);
* ``motion/grp/<group>/cmd/pos-abs``: write ``{"axsPos": [...]}`` to move a group;
  ``motion/grp/<group>/cmd/reset``;
* ``plc/app/Application/sym/PLC_PRG/...``: plain variables (the CODESYS SoftMotion note's ``dTest``
  among them), more can be added with ``add_variable``;
* ``datalayer/...``: the data layer's own nodes, and ``framework/metrics/system/...``
  (CPU load and memory, changing with time; ``_system_nodes``).

Commands run on a write (PUT) and on a create (POST), as ctrlX motion takes
them. ``cmd/reset`` takes no argument: an empty body is accepted, as a real
device accepts empty-argument commands (there is never an error to reset).
"""

from __future__ import annotations

from collections import Counter
from typing import Any

from ._motion_nodes import IPO, IPO_POS, motion_config
from ._system_nodes import FOLDERS, NODE_NAMES, SETTINGS, metrics, system_nodes
from .machine import Machine

AXES = "motion/axs"
GROUPS = "motion/grp"
PLC = "plc/app/Application/sym/PLC_PRG"
MIN_PUBLISH_MS = 5
"""Faster publishing would only burn the CPU the tests share with the server under test."""

ACTUAL, AXIS_CMD, RESET = "state/values/actual", "cmd/pos-abs", "cmd/reset"


class NodeError(Exception):
    """A failed node operation, answered as a Problem (status, data-layer title, detail)."""

    def __init__(self, status: int, title: str, detail: str) -> None:
        super().__init__(detail)
        self.status, self.title, self.detail = status, title, detail


def not_found(node: str) -> NodeError:
    """404 DL_INVALID_ADDRESS for ``node``."""
    return NodeError(404, "DL_INVALID_ADDRESS", f"node '{node}' does not exist")


class Snapshot:
    """The machine at one instant: every node read through it agrees on the time.

    Positions are computed per group, when one of its axes is first read: a
    read of one axis costs one group, not the whole machine (20 000 axes).
    """

    def __init__(self, machine: Machine, t: float | None = None) -> None:
        self.machine = machine
        self.t = machine.now() if t is None else t
        self._groups: dict[tuple[str, bool], list[float]] = {}

    def position(self, axis: str, *, setpoint: bool = False) -> float:
        """The actual position (or setpoint) of ``axis`` at this instant."""
        group = self.machine.group_of(axis)
        values = self._groups.get((group, setpoint))
        if values is None:
            at = self.machine.group_setpoints if setpoint else self.machine.group_positions
            values = self._groups[group, setpoint] = at(group, self.t).tolist()
        names = [a.name for a in self.machine.groups[group].axes]
        return float(values[names.index(axis)])


class NodeTree:
    """Every node of the mock, derived from the machine plus PLC variables and system nodes."""

    def __init__(self, machine: Machine) -> None:
        self.machine = machine
        self.variables: dict[str, dict[str, Any]] = {
            f"{PLC}/dTest": {"type": "double", "value": 0.0},
            f"{PLC}/arTargets": {"type": "arfloat64", "value": [0.0, 30.0, -25.0]},
        }
        self.system = system_nodes(MIN_PUBLISH_MS)
        self.positions: dict[str, str] = {}
        """Position node -> axis."""
        self.setpoints: dict[str, str] = {}
        """Setpoint node -> axis."""
        self._ipos: dict[str, str] = {}
        self._actuals: dict[str, str] = {}
        self._axis_cmds: dict[str, str] = {}
        self._group_cmds: dict[str, str] = {}
        self._resets: set[str] = set()
        for axis in machine.axes.values():
            if axis.position_node in self.positions:
                raise ValueError(f"nodes served twice: {axis.position_node}")
            self.positions[axis.position_node] = axis.name
            if axis.setpoint_node is not None:
                self.setpoints[axis.setpoint_node.strip("/")] = axis.name
            if axis.node is None:
                self._actuals[f"{AXES}/{axis.name}/{ACTUAL}"] = axis.name
                self.setpoints[f"{AXES}/{axis.name}/{IPO_POS}"] = axis.name
                self._ipos[f"{AXES}/{axis.name}/{IPO}"] = axis.name
                self._axis_cmds[f"{AXES}/{axis.name}/{AXIS_CMD}"] = axis.name
                self._resets.add(f"{AXES}/{axis.name}/{RESET}")
        for group in machine.groups:
            self._group_cmds[f"{GROUPS}/{group}/{AXIS_CMD}"] = group
            self._resets.add(f"{GROUPS}/{group}/{RESET}")
        motion_axes = [a for a in machine.axes.values() if a.node is None]
        self.config = motion_config(motion_axes, list(machine.groups.values()))
        """The motion app's configuration nodes (static Data)."""
        self.metrics = frozenset(metrics(0.0))
        self._children: dict[str, set[str]] = {}
        self._reindex()

    def _leaves(self) -> list[str]:
        return [
            *self.positions,
            *self.setpoints,
            *self._ipos,
            *self.config,
            *self.metrics,
            *self._actuals,
            *self._axis_cmds,
            *self._group_cmds,
            *self._resets,
            *self.variables,
            *self.system,
            NODE_NAMES,
        ]

    def _reindex(self) -> None:
        leaves = self._leaves()
        twice = sorted(n for n, k in Counter(leaves).items() if k > 1)
        if twice:
            raise ValueError(f"nodes served twice: {', '.join(twice)}")
        children: dict[str, set[str]] = {"": set()}
        for leaf in [*leaves, *FOLDERS]:
            parent = ""
            for part in leaf.split("/"):  # each prefix built once: 20 000 axes index in a second
                children[parent].add(part)
                parent = f"{parent}/{part}" if parent else part
                children.setdefault(parent, set())
        self._children = children

    def add_variable(self, node: str, type_: str, value: Any) -> None:
        """Add (or replace) a plain variable node, e.g. one with odd characters for tests."""
        node = node.strip("/")
        if node in self._leaves() and node not in self.variables:
            raise ValueError(f"node '{node}' is served already")
        self.variables[node] = {"type": type_, "value": value}
        self._reindex()

    def read(self, node: str, snapshot: Snapshot | None = None) -> dict[str, Any]:
        """The Data body of ``node``; ``snapshot`` is the instant to read axes at (default now)."""
        node = node.strip("/")
        if node in self.variables:
            return dict(self.variables[node])
        if node in self.system:
            return dict(self.system[node])
        if node in self.config:
            return dict(self.config[node])
        if node == NODE_NAMES:
            return {"type": "arstring", "value": sorted(self._leaves())}
        snapshot = snapshot or Snapshot(self.machine)
        if node in self.metrics:
            return metrics(snapshot.t)[node]
        axis = self.positions.get(node) or self._actuals.get(node)
        if axis is not None:
            pos = snapshot.position(axis)
            if node in self.positions:
                return {"type": "double", "value": pos}
            unit = self.machine.axes[axis].unit
            return {"type": "object", "value": {"actualPos": pos, "actualPosUnit": unit}}
        axis = self.setpoints.get(node) or self._ipos.get(node)
        if axis is not None:
            pos = snapshot.position(axis, setpoint=True)
            if node in self.setpoints:
                return {"type": "double", "value": pos}
            unit = self.machine.axes[axis].unit
            return {"type": "object", "value": {"ipoPos": pos, "ipoPosUnit": unit}}
        if node in self._children:
            raise NodeError(400, "DL_INVALID_OPERATION", f"node '{node}' cannot be read")
        raise not_found(node)

    def browse(self, node: str) -> list[str]:
        """Names of the children of ``node`` (``""`` is the root)."""
        node = node.strip("/")
        if node not in self._children:
            raise not_found(node)
        return sorted(self._children[node])

    def metadata(self, node: str) -> dict[str, Any]:
        """The ``metadata`` object of ``node`` (node class, allowed operations, unit)."""
        node = node.strip("/")
        if node not in self._children:
            raise not_found(node)
        command = self._is_command(node)
        axis = (
            self.positions.get(node)
            or self._actuals.get(node)
            or self.setpoints.get(node)
            or self._ipos.get(node)
        )
        readable = (
            node in self.variables
            or node in self.system
            or node in self.config
            or node in self.metrics
            or axis is not None
        )
        meta: dict[str, Any] = {
            "nodeClass": "Method" if command else "Resource",
            "operations": {
                "read": readable or node == NODE_NAMES,
                "write": command or node in self.variables or node in SETTINGS,
                "create": command,
                "delete": False,
                "browse": bool(self._children[node]),
            },
            "description": self._describe(node),
            "descriptionUrl": "",
            "displayName": node.rsplit("/", 1)[-1],
        }
        if node in self.positions or node in self.setpoints:
            meta["unit"] = self.machine.axes[self.positions.get(node) or self.setpoints[node]].unit
        elif node in self.metrics:
            meta["unit"] = "%" if node.endswith("percent") else "MB"
        return meta

    def write(self, node: str, body: Any, t: float | None = None) -> dict[str, Any] | None:
        """Write ``body`` (``{"type", "value"}``; None: no body) to ``node``.

        Returns the written Data, or None for a command without a result.
        """
        node = node.strip("/")
        if node in self._resets:
            return None  # nothing to reset: the simulated drives never fail
        if body is None:
            if node in self._children:
                raise NodeError(400, "DL_MISSING_ARGUMENT", f"node '{node}' needs a value")
            raise not_found(node)
        if not isinstance(body, dict) or "value" not in body:
            raise NodeError(400, "DL_TYPE_MISMATCH", "expected JSON {'type': ..., 'value': ...}")
        value = body["value"]
        stored = self.variables if node in self.variables else self.system
        if node in self.variables or node in SETTINGS:
            current = stored[node]
            if body.get("type", current["type"]) != current["type"]:
                raise NodeError(
                    400, "DL_TYPE_MISMATCH", f"node '{node}' has type {current['type']}"
                )
            if current["type"] == "object" and not isinstance(value, dict):
                raise NodeError(400, "DL_TYPE_MISMATCH", f"node '{node}' takes an object")
            stored[node] = {"type": current["type"], "value": value}
            return dict(stored[node])
        try:
            if node in self._axis_cmds:
                self.machine.command_axis(self._axis_cmds[node], _number(_unwrap(value)), t)
                return {"type": "object", "value": value}
            if node in self._group_cmds:
                target = _unwrap(value)
                if not isinstance(target, list):
                    raise ValueError("axsPos must be a list with one value per axis")
                self.machine.command(self._group_cmds[node], [_number(v) for v in target], t)
                return {"type": "object", "value": value}
        except ValueError as exc:
            raise NodeError(400, "DL_INVALID_VALUE", str(exc)) from exc
        if node in self._children:
            raise NodeError(400, "DL_INVALID_OPERATION", f"node '{node}' cannot be written")
        raise not_found(node)

    def create(self, node: str, body: Any, t: float | None = None) -> dict[str, Any] | None:
        """POST on ``node``: runs a command (as a write does); nothing else can be created."""
        node = node.strip("/")
        if self._is_command(node):
            return self.write(node, body, t)
        if node in self._children:
            raise NodeError(400, "DL_INVALID_OPERATION", f"nothing can be created at '{node}'")
        raise not_found(node)

    def delete(self, node: str) -> None:
        """DELETE on ``node``: no node of the mock can be deleted."""
        node = node.strip("/")
        if node in self._children:
            raise NodeError(403, "DL_PERMISSION_DENIED", f"node '{node}' cannot be deleted")
        raise not_found(node)

    def _is_command(self, node: str) -> bool:
        return node in self._axis_cmds or node in self._group_cmds or node in self._resets

    def _describe(self, node: str) -> str:
        if node in self.positions:
            return f"Actual position of axis {self.positions[node]}"
        if node in self._actuals:
            return f"Actual values of axis {self._actuals[node]}"
        if node in self.setpoints:
            return f"Setpoint (interpolated position) of axis {self.setpoints[node]}"
        if node in self._ipos:
            return f"Interpolated (setpoint) values of axis {self._ipos[node]}"
        if node in self._axis_cmds or node in self._group_cmds:
            return "Absolute move: write {'axsPos': target}"
        if node in self._resets:
            return "Reset: takes no argument"
        return ""


def _unwrap(value: Any) -> Any:
    return value.get("axsPos") if isinstance(value, dict) else value


def _number(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{value!r} is not a number")
    return float(value)
