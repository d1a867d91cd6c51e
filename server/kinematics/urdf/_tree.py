"""A URDF joint tree checked and flattened for the kernels behind ``UrdfChain``.

Links are put in depth-first order from the root (children in the order the
description lists them), so a parent always comes before its children. Every
link but the root carries the joint that connects it to its parent; mimic
joints are resolved to the movable joint they finally follow, so each joint's
value is ``multiplier * q[source] + offset`` (m or rad) with ``source`` an
index into the movable, non-mimic joints in description order.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .description import UrdfJoint, UrdfTree

Array = npt.NDArray[np.float64]

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")


@dataclass(frozen=True)
class Link:
    """One link of the flattened tree; ``kind`` is root, fixed, revolute or prismatic."""

    name: str
    parent: int  # index of the parent link, -1 for the root
    kind: str
    joint: str  # the joint from the parent ("" for the root)
    origin: Array  # 4x4, the joint frame at q = 0 in the parent link frame
    axis: Array  # (3,), unit, in the joint (= child link) frame
    source: int  # movable joint whose value drives this one, -1 if none
    multiplier: float
    offset: float
    depth: int  # joints between the root and this link


@dataclass(frozen=True)
class Tree:
    """A checked joint tree: links root first, and the movable joints' names, types, limits."""

    links: tuple[Link, ...]
    joint_names: tuple[str, ...]
    joint_types: tuple[str, ...]
    limits: Array  # (n, 2), lower then upper; continuous joints -inf, +inf

    def index(self, link: str) -> int:
        """Index of the link named ``link``; ValueError if there is none."""
        for i, item in enumerate(self.links):
            if item.name == link:
                return i
        raise ValueError(f"no link named {link!r} (links: {', '.join(self.names())})")

    def names(self) -> tuple[str, ...]:
        """Link names in tree order."""
        return tuple(link.name for link in self.links)

    def needed(self, outputs: Sequence[int]) -> list[int]:
        """Every link on the way from the root to any of ``outputs``, in tree order.

        Each walk up stops at a link already seen, so this is linear in the links
        (a union of ``path``s would be quadratic along a long chain).
        """
        seen: set[int] = set()
        for link in outputs:
            while link >= 0 and link not in seen:
                seen.add(link)
                link = self.links[link].parent
        return sorted(seen)

    def path(self, link: int) -> list[int]:
        """Indices of the links from the root to ``link``, both included."""
        out = [link]
        while self.links[out[-1]].parent >= 0:
            out.append(self.links[out[-1]].parent)
        return out[::-1]


def _unique(names: Sequence[str], what: str) -> None:
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise ValueError(f"two {what}s are named {name!r}")
        seen.add(name)


def _check_joint(joint: UrdfJoint, links: set[str]) -> None:
    if joint.type not in JOINT_TYPES:
        raise ValueError(
            f"joint {joint.name!r} has type {joint.type!r}; supported types are "
            + ", ".join(JOINT_TYPES)
        )
    for role, link in (("parent", joint.parent), ("child", joint.child)):
        if link not in links:
            raise ValueError(f"joint {joint.name!r}: its {role} link {link!r} is not defined")
    if joint.parent == joint.child:
        raise ValueError(f"joint {joint.name!r} connects link {joint.child!r} to itself")
    origin = np.asarray(joint.origin, dtype=np.float64)
    if origin.shape != (4, 4) or not np.isfinite(origin).all():
        raise ValueError(f"joint {joint.name!r}: origin must be a finite 4x4 matrix")
    if joint.type == "fixed":
        return
    axis = np.asarray(joint.axis, dtype=np.float64)
    if axis.shape != (3,) or not np.isfinite(axis).all() or not np.linalg.norm(axis) > 0.0:
        raise ValueError(
            f"joint {joint.name!r}: axis must be a non-zero 3-vector, got {joint.axis}"
        )
    if joint.type in ("revolute", "prismatic") and joint.mimic is None:
        if joint.limits is None:
            raise ValueError(f"joint {joint.name!r} ({joint.type}) needs limits (lower, upper)")
        lower, upper = joint.limits
        if not (math.isfinite(lower) and math.isfinite(upper) and lower <= upper):
            raise ValueError(
                f"joint {joint.name!r}: limits must be finite with lower <= upper, "
                f"got {joint.limits}"
            )


def _mimic_sources(
    joints: Sequence[UrdfJoint], movable: dict[str, int]
) -> dict[str, tuple[int, float, float]]:
    """Per moving joint: (index of the movable joint it follows, multiplier, offset)."""
    by_name = {joint.name: joint for joint in joints}
    out: dict[str, tuple[int, float, float]] = {}
    for joint in joints:
        if joint.type == "fixed":
            continue
        multiplier, offset = 1.0, 0.0
        seen = [joint.name]
        current: UrdfJoint = joint
        while current.mimic is not None:
            mimic = current.mimic
            found = by_name.get(mimic.joint)
            if found is None:
                raise ValueError(
                    f"joint {current.name!r} mimics {mimic.joint!r}, which is not a joint "
                    "of this robot"
                )
            target = found
            if target.type == "fixed":
                raise ValueError(
                    f"joint {current.name!r} mimics {mimic.joint!r}, which is a fixed joint"
                )
            if target.name in seen:
                raise ValueError("mimic joints form a cycle: " + " -> ".join(seen + [target.name]))
            # q_current = m q_target + o, and q_target = m' q_next + o' ...
            offset += multiplier * mimic.offset
            multiplier *= mimic.multiplier
            seen.append(target.name)
            current = target
        out[joint.name] = (movable[current.name], multiplier, offset)
    return out


def _preorder(root: str, children: dict[str, list[str]]) -> list[str]:
    order, stack = [], [root]
    while stack:
        link = stack.pop()
        order.append(link)
        stack.extend(reversed(children.get(link, [])))
    return order


def build(tree: UrdfTree) -> Tree:
    """Check ``tree`` and flatten it; ValueError naming exactly what is wrong."""
    _unique(tree.links, "link")
    _unique([joint.name for joint in tree.joints], "joint")
    if not tree.links:
        raise ValueError("the robot has no links")
    names = set(tree.links)
    parent_joint: dict[str, UrdfJoint] = {}
    for joint in tree.joints:
        _check_joint(joint, names)
        if joint.child in parent_joint:
            raise ValueError(
                f"link {joint.child!r} is the child of two joints: "
                f"{parent_joint[joint.child].name!r} and {joint.name!r}"
            )
        parent_joint[joint.child] = joint
    roots = [link for link in tree.links if link not in parent_joint]
    if len(roots) != 1:
        raise ValueError(
            "the links must form one tree with a single root link; roots found: "
            + (", ".join(roots) if roots else "none (the joints form a cycle)")
        )
    children: dict[str, list[str]] = {}
    for link in tree.links:  # children in the order the links are listed
        if link in parent_joint:
            children.setdefault(parent_joint[link].parent, []).append(link)
    order = _preorder(roots[0], children)
    if len(order) != len(tree.links):
        cut = sorted(names - set(order))
        raise ValueError(
            "links not connected to the root (the joints form a cycle): " + ", ".join(cut)
        )

    movable_joints = [j for j in tree.joints if j.type != "fixed" and j.mimic is None]
    movable = {joint.name: i for i, joint in enumerate(movable_joints)}
    sources = _mimic_sources(tree.joints, movable)
    index = {name: i for i, name in enumerate(order)}
    links: list[Link] = []
    for name in order:
        incoming = parent_joint.get(name)
        if incoming is None:
            links.append(Link(name, -1, "root", "", np.eye(4), np.zeros(3), -1, 0.0, 0.0, 0))
            continue
        axis = np.asarray(incoming.axis, dtype=np.float64)
        kind = {"continuous": "revolute"}.get(incoming.type, incoming.type)
        source, multiplier, offset = sources.get(incoming.name, (-1, 0.0, 0.0))
        parent = index[incoming.parent]
        links.append(
            Link(
                name=name,
                parent=parent,
                kind=kind,
                joint=incoming.name,
                origin=np.array(incoming.origin, dtype=np.float64),
                axis=axis / np.linalg.norm(axis) if kind != "fixed" else np.zeros(3),
                source=source,
                multiplier=multiplier,
                offset=offset,
                depth=links[parent].depth + 1,
            )
        )
    limits = np.array(
        [
            (-math.inf, math.inf) if j.type == "continuous" or j.limits is None else j.limits
            for j in movable_joints
        ],
        dtype=np.float64,
    ).reshape(-1, 2)
    return Tree(
        links=tuple(links),
        joint_names=tuple(j.name for j in movable_joints),
        joint_types=tuple(j.type for j in movable_joints),
        limits=limits,
    )
