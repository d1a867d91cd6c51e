"""A robot description's XML, read with lxml and cut down to what a viewer draws and moves.

Robot descriptions in the wild carry much that a viewer does not need:
``<transmission>``, ``<gazebo>``, ``<ros2_control>`` and tool-specific blocks
(some holding ``<joint>`` elements of their own), ``<collision>`` and
``<inertial>``. ``clean`` keeps the top-level ``<link>``, ``<joint>`` and
``<material>`` elements and, in links, the ``<visual>`` ones; it checks what
it keeps, naming the element's line, before yourdfpy reads it. What the URDF
specification allows but linkview cannot follow is made showable with a
warning: ``floating`` and ``planar`` joints become fixed at their origin.
``<capsule>`` (which yourdfpy does not read) is noted and handed over as a cylinder.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from lxml import etree

from ..sizes import MAX_LINKS, MAX_NAME_CHARS
from .model import UrdfError

KEPT = ("link", "joint", "material")
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")
FROZEN_TYPES = ("floating", "planar")
SHAPES = ("box", "cylinder", "sphere", "mesh", "capsule")
# Attributes holding numbers: element -> attribute -> how many numbers (1 or 3: mesh scale).
NUMBERS: dict[str, dict[str, tuple[int, ...]]] = {
    "origin": {"xyz": (3,), "rpy": (3,)},
    "axis": {"xyz": (3,)},
    "limit": {"lower": (1,), "upper": (1,), "effort": (1,), "velocity": (1,)},
    "mimic": {"multiplier": (1,), "offset": (1,)},
    "box": {"size": (3,)},
    "cylinder": {"radius": (1,), "length": (1,)},
    "sphere": {"radius": (1,)},
    "capsule": {"radius": (1,), "length": (1,)},
    "mesh": {"scale": (1, 3)},
    "color": {"rgba": (4,)},
}
# What each sized shape must say.
REQUIRED = {"box": ("size",), "cylinder": ("radius", "length"), "sphere": ("radius",)}
REQUIRED["capsule"] = REQUIRED["cylinder"]

_UNDEFINED_PREFIX = etree.ErrorTypes.NS_ERR_UNDEFINED_NAMESPACE
Where = Callable[[Any], str]
"""An element -> where it is, for messages (``file, line N``)."""


@dataclass
class Cleaned:
    """The cut-down ``<robot>``, what was made showable, and where each link and joint is."""

    root: Any
    warnings: list[str] = field(default_factory=list)
    capsules: dict[tuple[str, int], tuple[float, float]] = field(default_factory=dict)
    """(link, index of the visual) -> (radius, length) of a capsule (m)."""
    elements: dict[str, Any] = field(default_factory=dict)
    """``"joint 'name'"`` or ``"link 'name'"`` -> its element, to say where an error is."""


def parse(data: bytes, label: str) -> Any:
    """The ``<robot>`` root of ``data`` (from ``label``); UrdfError with the line if malformed.

    Attributes with an undeclared namespace prefix (``drake:acceleration``,
    left by exporters for their own tools) are taken as they are.
    """
    parser = etree.XMLParser(remove_comments=True, remove_pis=True, huge_tree=True, recover=True)
    try:
        root = etree.fromstring(data, parser)
    except etree.XMLSyntaxError as exc:
        raise UrdfError(f"{label}: malformed XML, line {exc.lineno}: {exc.msg}") from None
    errors = [e for e in parser.error_log if e.type != _UNDEFINED_PREFIX]
    if errors or root is None:
        first = errors[0] if errors else None
        line, msg = (first.line, first.message) if first else (1, "no root element")
        raise UrdfError(f"{label}: malformed XML, line {line}: {msg}")
    if root.tag.rpartition("}")[2] != "robot":
        raise UrdfError(f"{label}: the root element is <{root.tag}>, not <robot>")
    return root


def uses_xacro(root: Any) -> bool:
    """True if the file needs xacro: elements in its namespace, or ``$(...)``/``${...}`` values."""
    for el in root.iter():
        if not isinstance(el.tag, str):
            continue
        if el.tag.startswith("{") and "xacro" in el.tag.partition("}")[0]:
            return True
        if any("$(" in value or "${" in value for value in el.attrib.values()):
            return True
    return False


def _numbers(el: Any, owner: str, where: Where) -> None:
    for attr, counts in NUMBERS.get(el.tag, {}).items():
        text = el.get(attr)
        if text is None:
            continue
        try:
            values = [float(x) for x in text.split()]
        except ValueError:
            values = []
        if len(values) not in counts:
            need = " or ".join(str(c) for c in counts)
            raise UrdfError(
                f"{where(el)}: {owner}: <{el.tag} {attr}> must be {need} number(s), got {text!r}"
            )


def _visual(visual: Any, link: str, index: int, out: Cleaned, where: Where) -> None:
    owner = f"link {link!r}"
    for child in list(visual):
        if child.tag not in ("origin", "geometry", "material"):
            visual.remove(child)
    geometry = visual.find("geometry")
    found = [] if geometry is None else [str(c.tag) for c in geometry]
    for child in [] if geometry is None else list(geometry):
        if child.tag == "material" and visual.find("material") is None:
            visual.append(child)  # misplaced, as some exporters write it; still the colour
        elif child.tag not in SHAPES:
            geometry.remove(child)
    shapes = [] if geometry is None else [str(c.tag) for c in geometry]
    if len(shapes) != 1:
        raise UrdfError(
            f"{where(visual)}: a <visual> needs a <geometry> holding one "
            f"box, cylinder, sphere, capsule or mesh (found: {', '.join(found) or 'nothing'})"
        )
    shape = geometry[0]
    for el in visual.iter():
        _numbers(el, owner, where)
    for attr in REQUIRED.get(shape.tag, ()):
        if shape.get(attr) is None:
            raise UrdfError(f"{where(shape)}: {owner}: <{shape.tag}> without {attr}")
    if shape.tag == "mesh" and not shape.get("filename"):
        raise UrdfError(f"{where(shape)}: <mesh> without a filename")
    if shape.tag == "capsule":
        out.capsules[(link, index)] = (float(shape.get("radius")), float(shape.get("length")))
        shape.tag = "cylinder"


def _link(link: Any, out: Cleaned, where: Where) -> None:
    name = link.get("name")
    for child in list(link):
        if child.tag != "visual":
            link.remove(child)
    for index, visual in enumerate(link.findall("visual")):
        _visual(visual, name, index, out, where)


def _joint(joint: Any, joints: set[str | None], out: Cleaned, where: Where) -> None:
    name = joint.get("name")
    kind = joint.get("type")
    if kind in FROZEN_TYPES:
        out.warnings.append(
            f"{where(joint)}: joint {name!r} is {kind}: it is drawn fixed at its origin "
            "(linkview follows revolute, continuous and prismatic joints)"
        )
        joint.set("type", "fixed")
    elif kind not in JOINT_TYPES:
        raise UrdfError(
            f"{where(joint)}: joint {name!r} has type {kind!r}; supported types are "
            + ", ".join(JOINT_TYPES + FROZEN_TYPES)
        )
    for role in ("parent", "child"):
        ref = joint.find(role)
        if ref is None or not ref.get("link"):
            raise UrdfError(f'{where(joint)}: joint {name!r} has no <{role} link="..."/>')
    mimic = joint.find("mimic")
    if mimic is not None and not mimic.get("joint"):
        raise UrdfError(f"{where(mimic)}: joint {name!r}: <mimic> without a joint")
    if mimic is not None and mimic.get("joint") not in joints:
        # Published files do this (a hand renamed, its mimics not): the joint still
        # moves, it just follows its own value instead of another's.
        out.warnings.append(
            f"{where(mimic)}: joint {name!r} mimics {mimic.get('joint')!r}, which is not a "
            "joint of this robot: it is followed as a joint of its own"
        )
        joint.remove(mimic)
    for el in joint.iter():
        _numbers(el, f"joint {name!r}", where)


def clean(root: Any, where: Where) -> Cleaned:
    """``root`` cut down in place to what linkview uses (see the module doc), checked."""
    for el in root.iter():
        if isinstance(el.tag, str) and el.tag.startswith("{"):
            el.tag = el.tag.rpartition("}")[2]  # <robot xmlns="..."> and the like
    etree.cleanup_namespaces(root)
    out = Cleaned(root)
    for child in list(root):
        if child.tag not in KEPT:
            root.remove(child)
    links = 0
    for el in root:
        if el.tag in ("link", "joint") and not el.get("name"):
            raise UrdfError(f"{where(el)}: <{el.tag}> without a name")
        if el.tag in ("link", "joint") and len(el.get("name")) > MAX_NAME_CHARS:
            raise UrdfError(
                f"{where(el)}: <{el.tag}> name of {len(el.get('name'))} characters; "
                f"linkview takes at most {MAX_NAME_CHARS}"
            )
        links += el.tag == "link"
        if links > MAX_LINKS:
            raise UrdfError(
                f"{where(el)}: more than {MAX_LINKS} links; linkview draws at most "
                f"{MAX_LINKS} per robot"
            )
        if el.tag in ("link", "joint"):
            out.elements.setdefault(f"{el.tag} {el.get('name')!r}", el)
    if root.find("link") is None:
        raise UrdfError(f"{where(root)}: <robot> holds no <link>: there is nothing to draw")
    if not root.get("name"):
        # urdfdom refuses it; a viewer loses nothing by going on without one.
        out.warnings.append(f"{where(root)}: <robot> without a name")
        root.set("name", "robot")
    joints = {el.get("name") for el in root if el.tag == "joint"}
    for el in root:
        if el.tag == "link":
            _link(el, out, where)
        elif el.tag == "joint":
            _joint(el, joints, out, where)
        else:
            for item in el.iter():
                _numbers(item, f"material {el.get('name')!r}", where)
    return out
