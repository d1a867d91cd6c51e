"""The mock data layer's node tree: read, browse, metadata and write, over the simulated machine.

Nodes (``<axis>`` from the machine, ``<group>`` one per demo robot):

* ``motion/axs/<axis>/state/values/actual/pos``: double, deg or mm;
* ``motion/axs/<axis>/state/values/actual``: object ``{actualPos, actualPosUnit}``;
* ``motion/axs/<axis>/cmd/pos-abs``: write ``{"axsPos": x}`` (or a number) to move the axis;
* ``motion/grp/<group>/cmd/pos-abs``: write ``{"axsPos": [...]}`` to move a whole group;
* ``plc/app/Application/sym/PLC_PRG/...``: plain variables (the seed's ``dTest`` among them),
  more can be added with ``add_variable``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .machine import Machine

AXES = "motion/axs"
GROUPS = "motion/grp"
PLC = "plc/app/Application/sym/PLC_PRG"

ACTUAL, ACTUAL_POS, AXIS_CMD = "state/values/actual", "state/values/actual/pos", "cmd/pos-abs"


class NodeError(Exception):
    """A failed node operation, answered as a Problem (status, data-layer title, detail)."""

    def __init__(self, status: int, title: str, detail: str) -> None:
        super().__init__(detail)
        self.status, self.title, self.detail = status, title, detail


def not_found(node: str) -> NodeError:
    """404 DL_INVALID_ADDRESS for ``node``."""
    return NodeError(404, "DL_INVALID_ADDRESS", f"node '{node}' does not exist")


class NodeTree:
    """Every node of the mock, derived from the machine plus a few PLC variables."""

    def __init__(self, machine: Machine) -> None:
        self.machine = machine
        self.variables: dict[str, dict[str, Any]] = {
            f"{PLC}/dTest": {"type": "double", "value": 0.0},
            f"{PLC}/arTargets": {"type": "arfloat64", "value": [0.0, 30.0, -25.0]},
        }
        self._children: dict[str, set[str]] = {}
        self._reindex()

    def _reindex(self) -> None:
        leaves = [f"{AXES}/{a}/{s}" for a in self.machine.axes for s in (ACTUAL_POS, AXIS_CMD)]
        leaves += [f"{GROUPS}/{g}/{AXIS_CMD}" for g in self.machine.groups]
        leaves += list(self.variables)
        children: dict[str, set[str]] = {"": set()}
        for leaf in leaves:
            parts = leaf.split("/")
            for depth in range(len(parts)):
                parent = "/".join(parts[:depth])
                children.setdefault(parent, set()).add(parts[depth])
                children.setdefault("/".join(parts[: depth + 1]), set())
        self._children = children

    def add_variable(self, node: str, type_: str, value: Any) -> None:
        """Add (or replace) a plain variable node, e.g. one with odd characters for tests."""
        self.variables[node.strip("/")] = {"type": type_, "value": value}
        self._reindex()

    def read(self, node: str, positions: Mapping[str, float] | None = None) -> dict[str, Any]:
        """The Data body of ``node``; ``positions`` is a machine snapshot to read axes from."""
        node = node.strip("/")
        if node in self.variables:
            return dict(self.variables[node])
        axis, rest = self._axis_part(node)
        if axis is not None:
            pos = positions[axis] if positions is not None else self.machine.position(axis)
            if rest == ACTUAL_POS:
                return {"type": "double", "value": pos}
            if rest == ACTUAL:
                unit = self.machine.axes[axis].unit
                return {"type": "object", "value": {"actualPos": pos, "actualPosUnit": unit}}
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
        axis, rest = self._axis_part(node)
        command = node.endswith("/" + AXIS_CMD)
        readable = node in self.variables or (axis is not None and rest in (ACTUAL, ACTUAL_POS))
        meta: dict[str, Any] = {
            "nodeClass": "Method" if command else "Resource",
            "operations": {
                "read": readable,
                "write": command or node in self.variables,
                "create": False,
                "delete": False,
                "browse": bool(self._children[node]),
            },
            "description": _describe(node, axis, rest),
            "descriptionUrl": "",
            "displayName": node.rsplit("/", 1)[-1],
        }
        if axis is not None and rest in (ACTUAL, ACTUAL_POS):
            meta["unit"] = self.machine.axes[axis].unit
        return meta

    def write(self, node: str, body: Any, t: float | None = None) -> dict[str, Any]:
        """Write ``body`` (``{"type", "value"}``) to ``node``; returns the written Data."""
        node = node.strip("/")
        if not isinstance(body, dict) or "value" not in body:
            raise NodeError(400, "DL_TYPE_MISMATCH", "expected JSON {'type': ..., 'value': ...}")
        value = body["value"]
        if node in self.variables:
            current = self.variables[node]
            if body.get("type", current["type"]) != current["type"]:
                raise NodeError(
                    400, "DL_TYPE_MISMATCH", f"node '{node}' has type {current['type']}"
                )
            self.variables[node] = {"type": current["type"], "value": value}
            return dict(self.variables[node])
        try:
            axis, rest = self._axis_part(node)
            if axis is not None and rest == AXIS_CMD:
                self.machine.command_axis(axis, _number(_unwrap(value)), t)
                return {"type": "object", "value": value}
            group = self._group_part(node)
            if group is not None:
                target = _unwrap(value)
                if not isinstance(target, list):
                    raise ValueError("axsPos must be a list with one value per axis")
                self.machine.command(group, [_number(v) for v in target], t)
                return {"type": "object", "value": value}
        except ValueError as exc:
            raise NodeError(400, "DL_INVALID_VALUE", str(exc)) from exc
        if node in self._children:
            raise NodeError(400, "DL_INVALID_OPERATION", f"node '{node}' cannot be written")
        raise not_found(node)

    def _axis_part(self, node: str) -> tuple[str | None, str]:
        """(axis, rest) for ``motion/axs/<axis>/<rest>``; (None, "") otherwise."""
        if not node.startswith(AXES + "/"):
            return None, ""
        axis, _, rest = node[len(AXES) + 1 :].partition("/")
        return (axis, rest) if axis in self.machine.axes else (None, "")

    def _group_part(self, node: str) -> str | None:
        if node.startswith(GROUPS + "/") and node.endswith("/" + AXIS_CMD):
            group = node[len(GROUPS) + 1 : -len(AXIS_CMD) - 1]
            return group if group in self.machine.groups else None
        return None


def _unwrap(value: Any) -> Any:
    return value.get("axsPos") if isinstance(value, dict) else value


def _number(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{value!r} is not a number")
    return float(value)


def _describe(node: str, axis: str | None, rest: str) -> str:
    if axis is not None and rest == ACTUAL_POS:
        return f"Actual position of axis {axis}"
    if axis is not None and rest == ACTUAL:
        return f"Actual values of axis {axis}"
    if node.endswith("/" + AXIS_CMD):
        return "Absolute move: write {'axsPos': target}"
    return ""
