"""A robot whose URDF is not there yet, drawn as a placeholder chain until one is chosen.

``discover`` writes ``kinematics = { type = "urdf", file = "<robot>.urdf" }``
with a ``TODO`` for a joint transformation linkview cannot compute. ``check``
names that file until it exists; a server that may edit its cell
(``--allow-edits``) runs the robot anyway, so that its description can be
picked on the page (docs/commissioning.md). Its joints become a chain, as
``discover`` sets out loose axes: each joint 200 mm above the one before,
turning about (or sliding along) +Z as its node's unit says, with no
visuals (the page draws ball and stick). The joints keep the names the
entries give (``joint = "..."``), else ``j1``, ``j2``, ... The chain is a
URDF written into the mesh cache, named by its content, and loaded as any.
"""

from __future__ import annotations

import dataclasses
import hashlib
from xml.sax.saxutils import quoteattr

from . import schema
from .families import Built, Where, build

STEP_M = 0.2
LINEAR_UNITS = ("mm", "m")
FOLDER = "placeholders"
SLIDE = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'
"""A prismatic joint's limits (URDF requires them): a metre each way."""


def missing_description(spec: schema.Robot, where: Where) -> str | None:
    """The URDF file ``spec``'s kinematics names, if it is not there."""
    kinematics = spec.kinematics
    if not isinstance(kinematics, schema.Urdf):
        return None
    path = where.resolve(kinematics.file)
    return None if path.exists() else str(path)


def _urdf(joints: list[schema.Joint]) -> str:
    lines = ['<robot name="placeholder">', '  <link name="base"/>']
    for k, entry in enumerate(joints, 1):
        name = quoteattr(entry.joint or f"j{k}")
        kind = "prismatic" if entry.unit in LINEAR_UNITS else "continuous"
        limit = "" if kind != "prismatic" else SLIDE
        parent = "base" if k == 1 else f"l{k - 1}"
        lines += [
            f'  <link name="l{k}"/>',
            f'  <joint name={name} type="{kind}"><parent link="{parent}"/><child link="l{k}"/>',
            f'    <origin xyz="0 0 {0.0 if k == 1 else STEP_M}"/><axis xyz="0 0 1"/>{limit}',
            "  </joint>",
        ]
    return "\n".join([*lines, "</robot>", ""])


def placeholder(spec: schema.Robot, where: Where, missing: str) -> Built:
    """A chain of one joint per joints entry, standing in for the description at ``missing``,
    with a warning that says so."""
    text = _urdf(spec.joints)
    folder = where.cache_dir / FOLDER
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{hashlib.sha256(text.encode()).hexdigest()[:16]}.urdf"
    if not path.exists():
        path.write_text(text, encoding="utf-8")
    built = build(schema.Urdf(type="urdf", file=str(path)), where)
    note = f"its description {missing} is not there: drawn as a placeholder chain"
    return dataclasses.replace(built, warnings=(f"{note} until one is picked",))
