"""Read a URDF or xacro file into a ``UrdfRobot``: cleaned with lxml, parsed by yourdfpy.

The steps: xacro files are expanded (``_xacro``); the XML is cut down to what
linkview uses and checked with line numbers (``_xml``); yourdfpy reads what is
left; mesh references are resolved (``_paths``). What cannot be shown as
written but need not stop the robot (a missing mesh, a floating joint) becomes
a warning on the robot; anything else is a UrdfError that says where.
"""

from __future__ import annotations

import io
import logging
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yourdfpy
from lxml import etree

from server.kinematics.urdf import UrdfChain, UrdfJoint, UrdfMimic, UrdfTree

from ..sandbox import Confinement
from ..sizes import MAX_DESCRIPTION_MB, MAX_JOINTS
from . import _xacro, _xml
from ._paths import Packages, resolve_mesh
from .model import (
    BoxGeometry,
    CapsuleGeometry,
    CylinderGeometry,
    Geometry,
    MeshGeometry,
    SphereGeometry,
    UrdfError,
    UrdfRobot,
    Visual,
    stand_in,
)

Rgba = tuple[float, float, float, float]
Vec3 = tuple[float, float, float]
_NAMED = re.compile(r"(joint|link) '([^']*)'")


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


def _scale(scale: Any) -> Vec3:
    if scale is None:
        return (1.0, 1.0, 1.0)
    values = np.broadcast_to(np.asarray(scale, dtype=np.float64).reshape(-1), (3,))
    return (float(values[0]), float(values[1]), float(values[2]))


def _rgba(material: Any) -> Rgba | None:
    if material is None or material.color is None:
        return None
    c = np.asarray(material.color.rgba, dtype=np.float64)
    return (float(c[0]), float(c[1]), float(c[2]), float(c[3]))


def _colours(robot: Any) -> dict[str, Rgba]:
    """Named material colours: top-level ones, then any defined inside a visual."""
    named: dict[str, Rgba] = {}
    materials = list(robot.materials) + [
        visual.material for link in robot.links for visual in link.visuals if visual.material
    ]
    for material in materials:
        rgba = _rgba(material)
        if material.name and rgba is not None and material.name not in named:
            named[material.name] = rgba
    return named


class _Reader:
    """One description file being read: where it is, its packages, what it warned about."""

    def __init__(
        self,
        path: Path,
        packages: Packages,
        args: Mapping[str, str],
        confinement: Confinement | None = None,
    ) -> None:
        self.path = path
        self.packages = packages
        self.args = args
        self.confinement = confinement
        self.expanded = False
        self.folders = [path.parent]
        """Where relative mesh paths are looked for: the file's folder, then its includes'."""
        self.warnings: list[str] = []

    def where(self, el: Any) -> str:
        """Where ``el`` is, for messages: the file and line (of the expanded text for xacro)."""
        if self.expanded:
            return f"{self.path}, line {el.sourceline} of its xacro output"
        return f"{self.path}, line {el.sourceline}"

    def root(self) -> Any:
        """The ``<robot>`` element, xacro expanded where the file uses it."""
        if _xacro.is_xacro(self.path):
            return self._expand()
        if not self.path.is_file():
            raise UrdfError(f"URDF file {self.path} not found")
        try:
            size = self.path.stat().st_size
            if size > MAX_DESCRIPTION_MB * 1024 * 1024:
                raise UrdfError(
                    f"URDF file {self.path} is {size / 1e6:.0f} MB; linkview reads at most "
                    f"{MAX_DESCRIPTION_MB} MB"
                )
            data = self.path.read_bytes()
        except OSError as exc:
            raise UrdfError(f"URDF file {self.path}: cannot read it ({exc.strerror})") from None
        root = _xml.parse(data, str(self.path))
        return self._expand() if _xml.uses_xacro(root) else root

    def _expand(self) -> Any:
        expanded = _xacro.expand(self.path, self.args, self.packages, self.confinement)
        self.warnings += expanded.warnings
        self.expanded = True
        self.folders += [f.parent for f in expanded.included if f.parent not in self.folders]
        return _xml.parse(expanded.text.encode(), f"{self.path} (expanded by xacro)")

    def locate(self, message: str, cleaned: _xml.Cleaned) -> str:
        """``message`` prefixed with where the first joint or link it names is."""
        for kind, name in _NAMED.findall(message):
            el = cleaned.elements.get(f"{kind} {name!r}")
            if el is not None:
                return f"{self.where(el)}: {message}"
        return f"{self.path}: {message}"

    def geometry(self, geometry: Any, link: str) -> Geometry:
        if geometry.mesh is not None:
            uri = geometry.mesh.filename or ""
            path = resolve_mesh(uri, link, self.folders, self.packages)
            return MeshGeometry(path, _scale(geometry.mesh.scale), uri)
        if geometry.box is not None:
            size = np.asarray(geometry.box.size, dtype=np.float64)
            return BoxGeometry((float(size[0]), float(size[1]), float(size[2])))
        if geometry.cylinder is not None:
            return CylinderGeometry(
                float(geometry.cylinder.radius), float(geometry.cylinder.length)
            )
        assert geometry.sphere is not None  # _xml.clean let no other shape through
        return SphereGeometry(float(geometry.sphere.radius))


def _empty(geometry: Geometry) -> bool:
    """True for a primitive with no volume (``<sphere radius="0"/>``): nothing to draw."""
    if isinstance(geometry, BoxGeometry):
        return min(geometry.size) <= 0.0
    if isinstance(geometry, CylinderGeometry):
        return geometry.radius <= 0.0 or geometry.length <= 0.0
    if isinstance(geometry, CapsuleGeometry | SphereGeometry):
        return geometry.radius <= 0.0
    return False


def _ends(tree: UrdfTree) -> dict[str, tuple[Vec3, ...]]:
    ends: dict[str, list[Vec3]] = {}
    for joint in tree.joints:
        xyz = np.asarray(joint.origin)[:3, 3]
        if np.linalg.norm(xyz) > 1e-6:
            ends.setdefault(joint.parent, []).append((float(xyz[0]), float(xyz[1]), float(xyz[2])))
    return {link: tuple(points) for link, points in ends.items()}


def _visuals(
    robot: Any, reader: _Reader, cleaned: _xml.Cleaned, ends: Mapping[str, tuple[Vec3, ...]]
) -> dict[str, tuple[Visual, ...]]:
    named = _colours(robot)
    out: dict[str, tuple[Visual, ...]] = {}
    for link in robot.links:
        visuals = []
        for index, visual in enumerate(link.visuals):
            material = visual.material
            rgba = _rgba(material)
            if rgba is None and material is not None and material.name:
                rgba = named.get(material.name)
            origin = (
                np.eye(4) if visual.origin is None else np.array(visual.origin, dtype=np.float64)
            )
            capsule = cleaned.capsules.get((link.name, index))
            geometry: Geometry
            if capsule is not None:
                geometry = CapsuleGeometry(*capsule)
            else:
                try:
                    geometry = reader.geometry(visual.geometry, link.name)
                except UrdfError as exc:
                    reader.warnings.append(reader.locate(f"{exc}; drawn as a stand-in", cleaned))
                    visuals.append(stand_in(ends.get(link.name, ()), rgba))
                    continue
            if not _empty(geometry):
                visuals.append(Visual(origin, geometry, rgba))
        out[link.name] = tuple(visuals)
    return out


def load_urdf(
    path: str | Path,
    packages: Mapping[str, str | Path] | None = None,
    tip: str | None = None,
    args: Mapping[str, str] | None = None,
    confinement: Confinement | None = None,
) -> UrdfRobot:
    """Load the URDF or xacro file at ``path``: kinematics, joints, limits, each link's visuals.

    ``packages`` maps ROS package names to folders (used as given: resolve
    relative ones first); packages not given are searched for above the file
    (see ``_paths``). ``args`` are xacro arguments, expanded in a worker within
    ``confinement`` (default: reads in the file's folder and its packages, no
    environment variables, the default limits). ``tip`` is the link
    ``forward``/``inverse`` work on (default: see ``UrdfChain``). Raises
    UrdfError, whose message says what is wrong and where, for any file that
    cannot be used; what can be shown in part is in ``UrdfRobot.warnings``.
    """
    path = Path(path)
    folders = {name: Path(folder) for name, folder in (packages or {}).items()}
    reader = _Reader(path, Packages(folders, path.parent), args or {}, confinement)
    cleaned = _xml.clean(reader.root(), reader.where)
    reader.warnings += cleaned.warnings
    # yourdfpy logs and then retries malformed files leniently; _xml has
    # already rejected those, so its log would only be noise.
    previous = logging.getLogger("yourdfpy").level
    logging.getLogger("yourdfpy").setLevel(logging.CRITICAL)
    try:
        parsed = yourdfpy.URDF.load(
            io.BytesIO(etree.tostring(cleaned.root)),
            build_scene_graph=False,
            load_meshes=False,
        )
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
        raise UrdfError(reader.locate(str(exc), cleaned)) from None
    if chain.n_joints > MAX_JOINTS:
        raise UrdfError(
            f"{path}: {chain.n_joints} movable joints; linkview follows at most {MAX_JOINTS} "
            "per robot"
        )
    ends = _ends(tree)
    visuals = _visuals(robot, reader, cleaned, ends)
    return UrdfRobot(
        name=str(robot.name),
        path=path,
        chain=chain,
        visuals=visuals,
        warnings=tuple(reader.warnings),
        ends=ends,
    )
