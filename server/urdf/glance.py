"""A first look at a description file, much cheaper than loading it: is it a robot, how many joints.

Picking a description for a robot means looking at every URDF and xacro file
on the machine (``server.commissioning.descriptions``); most are not the one,
and loading each (expanding xacro, resolving meshes) would take minutes. A
plain URDF's movable joints are read from its XML directly; a xacro file that
only defines macros and properties (one that other files include) is not a
robot on its own. Whatever passes is loaded properly before it is offered.
"""

from __future__ import annotations

from pathlib import Path

from . import _xml
from ._xacro import is_xacro
from .model import UrdfError

MOVABLE = ("revolute", "continuous", "prismatic")
MAX_BYTES = 20 << 20
"""Files larger than this are not looked at (a URDF of that size is a mesh pasted in)."""
_DEFINITIONS = ("macro", "property", "include", "arg")
"""xacro elements that define but draw nothing: a file of only these is a library."""


def glance(path: Path) -> tuple[str, ...] | None:
    """The movable, non-mimic joints of a plain URDF, in file order; None where only a
    full load can tell (the file uses xacro). UrdfError: not a robot description."""
    try:
        if path.stat().st_size > MAX_BYTES:
            raise UrdfError(f"{path}: larger than {MAX_BYTES >> 20} MB")
        data = path.read_bytes()
    except OSError as exc:
        raise UrdfError(f"{path}: cannot read it ({exc.strerror})") from None
    root = _xml.parse(data, str(path))
    if is_xacro(path) or _xml.uses_xacro(root):
        if all(_local(el.tag) in _DEFINITIONS for el in root if isinstance(el.tag, str)):
            raise UrdfError(f"{path}: only xacro definitions, included by other files")
        return None
    return tuple(
        str(joint.get("name"))
        for joint in root.findall("joint")
        if joint.get("type") in MOVABLE and joint.find("mimic") is None
    )


def _local(tag: str) -> str:
    """An element's name without its namespace (``{...xacro}macro`` -> ``macro``)."""
    return tag.rpartition("}")[2]
