"""Read a URDF file into a ``UrdfRobot``: parsed by yourdfpy, checked here, paths resolved."""

from __future__ import annotations

import logging
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yourdfpy
from lxml import etree

from server.kinematics.urdf import UrdfChain, UrdfJoint, UrdfMimic, UrdfTree

from ._paths import resolve_mesh
from .model import (
    BoxGeometry,
    CylinderGeometry,
    Geometry,
    MeshGeometry,
    SphereGeometry,
    UrdfError,
    UrdfRobot,
    Visual,
)

_XACRO = "http://www.ros.org/wiki/xacro"


def _parse_xml(path: Path) -> Any:
    """The XML root of ``path``; UrdfError for a missing file or malformed XML (with its line)."""
    if not path.is_file():
        raise UrdfError(f"URDF file {path} not found")
    try:
        parser = etree.XMLParser(remove_blank_text=True, remove_comments=True)
        root = etree.parse(str(path), parser).getroot()
    except etree.XMLSyntaxError as exc:
        raise UrdfError(f"{path}: malformed XML, line {exc.lineno}: {exc.msg}") from None
    if root.tag != "robot":
        raise UrdfError(f"{path}: the root element is <{root.tag}>, not <robot>")
    if any(isinstance(el.tag, str) and el.tag.startswith("{" + _XACRO) for el in root.iter()):
        raise UrdfError(f"{path} is a xacro file: expand it to plain URDF with xacro first")
    for el in root.iter("link", "joint"):
        if not el.get("name"):
            raise UrdfError(f"{path}, line {el.sourceline}: <{el.tag}> without a name")
    for el in root.iter("visual"):
        geometry = el.find("geometry")
        shapes = [] if geometry is None else [str(child.tag) for child in geometry]
        if len(shapes) != 1 or shapes[0] not in ("box", "cylinder", "sphere", "mesh"):
            raise UrdfError(
                f"{path}, line {el.sourceline}: a <visual> needs a <geometry> holding one "
                f"box, cylinder, sphere or mesh (found: {', '.join(shapes) or 'nothing'})"
            )
        mesh = el.find("geometry/mesh")
        if mesh is not None and not mesh.get("filename"):
            raise UrdfError(f"{path}, line {mesh.sourceline}: <mesh> without a filename")
    for el in root.iter("joint"):
        for role in ("parent", "child"):
            ref = el.find(role)
            if ref is None or not ref.get("link"):
                raise UrdfError(
                    f"{path}, line {el.sourceline}: joint {el.get('name')!r} has no "
                    f'<{role} link="..."/>'
                )
    return root


def _joint(joint: Any) -> UrdfJoint:
    limits = None
    if joint.limit is not None:
        # As in urdfdom, a <limit> without lower or upper means 0 there.
        limits = (float(joint.limit.lower or 0.0), float(joint.limit.upper or 0.0))
    mimic = None
    if joint.mimic is not None:
        mimic = UrdfMimic(
            joint.mimic.joint, float(joint.mimic.multiplier), float(joint.mimic.offset)
        )
    axis = np.array([1.0, 0.0, 0.0] if joint.axis is None else joint.axis, dtype=np.float64)
    return UrdfJoint(
        name=joint.name,
        type=joint.type,
        parent=joint.parent,
        child=joint.child,
        origin=np.eye(4) if joint.origin is None else np.array(joint.origin, dtype=np.float64),
        axis=(float(axis[0]), float(axis[1]), float(axis[2])),
        limits=limits,
        mimic=mimic,
    )


def _scale(scale: Any) -> tuple[float, float, float]:
    if scale is None:
        return (1.0, 1.0, 1.0)
    values = np.broadcast_to(np.asarray(scale, dtype=np.float64).reshape(-1), (3,))
    return (float(values[0]), float(values[1]), float(values[2]))


def _geometry(geometry: Any, link: str, urdf_dir: Path, packages: Mapping[str, Path]) -> Geometry:
    if geometry.mesh is not None:
        uri = geometry.mesh.filename or ""
        path = resolve_mesh(uri, link, urdf_dir, packages)
        return MeshGeometry(path, _scale(geometry.mesh.scale), uri)
    if geometry.box is not None:
        size = np.asarray(geometry.box.size, dtype=np.float64)
        return BoxGeometry((float(size[0]), float(size[1]), float(size[2])))
    if geometry.cylinder is not None:
        return CylinderGeometry(float(geometry.cylinder.radius), float(geometry.cylinder.length))
    if geometry.sphere is not None:
        return SphereGeometry(float(geometry.sphere.radius))
    raise UrdfError(f"link {link!r}: a <visual> without a box, cylinder, sphere or mesh")


def _colours(robot: Any) -> dict[str, tuple[float, float, float, float]]:
    """Named material colours: top-level ones, then any defined inside a visual."""
    named: dict[str, tuple[float, float, float, float]] = {}
    materials = list(robot.materials) + [
        visual.material for link in robot.links for visual in link.visuals if visual.material
    ]
    for material in materials:
        if material.name and material.color is not None and material.name not in named:
            rgba = np.asarray(material.color.rgba, dtype=np.float64)
            named[material.name] = (float(rgba[0]), float(rgba[1]), float(rgba[2]), float(rgba[3]))
    return named


def _visuals(robot: Any, path: Path, packages: Mapping[str, Path]) -> dict[str, tuple[Visual, ...]]:
    named = _colours(robot)
    out: dict[str, tuple[Visual, ...]] = {}
    for link in robot.links:
        visuals = []
        for visual in link.visuals:
            material, rgba = visual.material, None
            if material is not None and material.color is not None:
                c = np.asarray(material.color.rgba, dtype=np.float64)
                rgba = (float(c[0]), float(c[1]), float(c[2]), float(c[3]))
            elif material is not None and material.name:
                rgba = named.get(material.name)
            origin = (
                np.eye(4) if visual.origin is None else np.array(visual.origin, dtype=np.float64)
            )
            try:
                geometry = _geometry(visual.geometry, link.name, path.parent, packages)
            except UrdfError as exc:
                raise UrdfError(f"{path}: {exc}") from None
            visuals.append(Visual(origin, geometry, rgba))
        out[link.name] = tuple(visuals)
    return out


def load_urdf(
    path: str | Path, packages: Mapping[str, str | Path] | None = None, tip: str | None = None
) -> UrdfRobot:
    """Load the URDF at ``path``: kinematics, joint order and limits, each link's visuals.

    ``packages`` maps ``package://`` names to folders (used as given: resolve
    relative ones first). ``tip`` is the link ``forward``/``inverse`` work on
    (default: see ``UrdfChain``). Raises UrdfError, whose message says what is
    wrong, for any file that cannot be used.
    """
    path = Path(path)
    folders = {name: Path(folder) for name, folder in (packages or {}).items()}
    _parse_xml(path)
    # yourdfpy logs and then retries malformed files leniently; _parse_xml has
    # already rejected those, so its log would only be noise.
    previous = logging.getLogger("yourdfpy").level
    logging.getLogger("yourdfpy").setLevel(logging.CRITICAL)
    try:
        parsed = yourdfpy.URDF.load(str(path), build_scene_graph=False, load_meshes=False)
    except (KeyError, AttributeError, ValueError, TypeError, IndexError) as exc:
        raise UrdfError(f"{path}: cannot read the robot description ({exc!r})") from None
    finally:
        logging.getLogger("yourdfpy").setLevel(previous)
    robot = parsed.robot
    tree = UrdfTree(
        links=tuple(link.name for link in robot.links),
        joints=tuple(_joint(joint) for joint in robot.joints),
    )
    try:
        chain = UrdfChain(tree, tip)
    except ValueError as exc:
        raise UrdfError(f"{path}: {exc}") from None
    return UrdfRobot(
        name=str(robot.name), path=path, chain=chain, visuals=_visuals(robot, path, folders)
    )
