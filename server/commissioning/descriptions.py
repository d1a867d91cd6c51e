"""Robot descriptions found on this machine, for a robot that has none yet.

Where a person would look: the cell file's folder; description packages
installed in the environment (the Python environment's ``site-packages`` and
``share`` folders, where pip and conda put them, e.g. ``pybullet_data``,
``rtbdata``); and ROS package paths (``ROS_PACKAGE_PATH``, the ``share``
folders of ``AMENT_PREFIX_PATH`` and ``CMAKE_PREFIX_PATH``, ``/opt/ros/*``).
Each is searched a few folders deep for ``.urdf`` and ``.xacro`` files. A
plain URDF's joints are counted from its XML; the rest are loaded, within a
time budget per listing (what is left is looked at by the next one). What has
been loaded is remembered by file and modification time.

Only files found this way can be previewed or chosen (by ``id``): the page
never names a path of its own.
"""

from __future__ import annotations

import hashlib
import os
import re
import site
import sys
import threading
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..kinematics import pose7_from_matrix
from ..urdf import UrdfError, UrdfRobot, load_urdf
from ..urdf.glance import glance
from .errors import CommissioningError

SUFFIXES = (".urdf", ".xacro")
DEPTH = 5
"""Folders searched below each root (``rtbdata/xacro/kuka_description/kr6/urdf/x.xacro``)."""
MAX_FILES = 5000
BUDGET_S = 15.0
"""Time one listing may spend loading files whose joints only a full load can count."""
SKIPPED = {"__pycache__", "node_modules", ".git", ".venv", "venv"}
_PACKAGE_REF = re.compile(r"(?:package://|\$\(find\s+)([A-Za-z0-9_\-]+)")


@dataclass(frozen=True)
class Root:
    """A folder to search, and what people call that kind of place."""

    folder: Path
    origin: str


@dataclass(frozen=True)
class Description:
    """One description file: its joints (movable, file order) or why it cannot be used."""

    path: Path
    origin: str
    joints: tuple[str, ...]
    error: str | None = None

    @property
    def id(self) -> str:
        """What the page names it by."""
        return hashlib.sha256(str(self.path).encode()).hexdigest()[:16]


def roots(cell_folder: Path | None, environ: Mapping[str, str]) -> list[Root]:
    """Every folder to search, the cell's first; ones that do not exist are left out."""
    found = [] if cell_folder is None else [Root(cell_folder, "cell folder")]
    environment = [*site.getsitepackages(), os.path.join(sys.prefix, "share")]
    found += [Root(Path(p), "Python environment") for p in environment]
    ros = [p for p in environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    for variable in ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH"):
        prefixes = environ.get(variable, "").split(os.pathsep)
        ros += [os.path.join(p, "share") for p in prefixes if p]
    ros += sorted(str(p / "share") for p in Path("/opt/ros").glob("*"))
    found += [Root(Path(p), "ROS packages") for p in ros]
    unique: dict[Path, Root] = {}
    for root in found:
        try:
            key = root.folder.resolve()
        except OSError:
            continue
        if key.is_dir() and key not in unique:
            unique[key] = Root(key, root.origin)
    return list(unique.values())


def files(root: Root, depth: int = DEPTH) -> Iterator[Path]:
    """The ``.urdf`` and ``.xacro`` files at most ``depth`` folders below ``root``."""
    top = str(root.folder)
    for folder, children, names in os.walk(top):
        level = folder[len(top) :].count(os.sep)
        children[:] = sorted(
            c
            for c in children
            if level < depth and not c.startswith(".") and c not in SKIPPED
            and not c.endswith(".dist-info")
        )  # fmt: skip
        for name in sorted(names):
            if name.lower().endswith(SUFFIXES):
                yield Path(folder) / name


def ros_packages(found: list[Root]) -> dict[str, Path]:
    """ROS package name -> folder, for the packages of the ROS roots (``package.xml``)."""
    packages: dict[str, Path] = {}
    for root in found:
        if root.origin != "ROS packages":
            continue
        for manifest in sorted(root.folder.glob("*/package.xml")) + sorted(
            root.folder.glob("*/*/package.xml")
        ):
            packages.setdefault(manifest.parent.name, manifest.parent)
    return packages


@dataclass(frozen=True)
class Listing:
    """Descriptions with the wanted number of joints, and how much was looked at."""

    matching: list[Description]
    examined: int
    unreadable: int
    pending: int
    """Files not looked at within the time budget (the next listing goes on)."""


class Catalog:
    """What was found where, remembered between listings (by file and modification time)."""

    def __init__(self, environ: Mapping[str, str] | None = None) -> None:
        self.environ = os.environ if environ is None else environ
        self._seen: dict[Path, tuple[int, Description]] = {}
        self._by_id: dict[str, Description] = {}
        self._lock = threading.Lock()

    def listing(self, joints: int, cell_folder: Path | None, budget_s: float = BUDGET_S) -> Listing:
        """Descriptions with ``joints`` movable joints (blocking: run it in a thread)."""
        found = roots(cell_folder, self.environ)
        packages = ros_packages(found)
        deadline = time.monotonic() + budget_s
        matching: list[Description] = []
        examined = unreadable = pending = 0
        seen: set[Path] = set()
        for root in found:
            for path in files(root):
                if path in seen or len(seen) >= MAX_FILES:
                    continue
                seen.add(path)
                described = self._describe(path, root.origin, packages, deadline)
                if described is None:
                    pending += 1
                    continue
                examined += 1
                if described.error is not None:
                    unreadable += 1
                elif len(described.joints) == joints:
                    matching.append(described)
        return Listing(matching, examined, unreadable, pending)

    def _describe(
        self, path: Path, origin: str, packages: dict[str, Path], deadline: float
    ) -> Description | None:
        try:
            mtime = path.stat().st_mtime_ns
        except OSError:
            return Description(path, origin, (), "cannot be read")
        with self._lock:
            known = self._seen.get(path)
        if known is not None and known[0] == mtime:
            return known[1]
        try:
            names = glance(path)
            if names is None:
                if time.monotonic() > deadline:
                    return None
                names = load(path, packages_for(path, origin, packages)).joint_names
            described = Description(path, origin, names)
        except UrdfError as exc:
            described = Description(path, origin, (), str(exc))
        except Exception as exc:  # a broken file may make xacro or yourdfpy raise anything
            described = Description(path, origin, (), f"cannot be read: {exc!r}")
        with self._lock:
            self._seen[path] = (mtime, described)
            self._by_id[described.id] = described
        return described

    def get(self, id: str) -> Description:
        """A description this catalog listed; 404 for any other."""
        with self._lock:
            found = self._by_id.get(id)
        if found is None or found.error is not None:
            raise CommissioningError(404, f"no description {id!r} was listed: list them again")
        return found

    def packages(self, description: Description) -> dict[str, Path]:
        """The ROS packages ``description`` names that only the ROS package paths know."""
        return packages_for(
            description.path, description.origin, ros_packages(roots(None, self.environ))
        )


def packages_for(path: Path, origin: str, known: dict[str, Path]) -> dict[str, Path]:
    """For a file of the ROS roots: the packages its text names that ``known`` has
    (the search above the file finds those of one ``share`` folder, not across paths)."""
    if origin != "ROS packages":
        return {}
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return {}
    return {name: known[name] for name in _PACKAGE_REF.findall(text) if name in known}


def load(path: Path, packages: dict[str, Path]) -> UrdfRobot:
    """The description at ``path``, loaded as a cell would load it."""
    return load_urdf(path, packages)


def preview(description: Description, packages: dict[str, Path]) -> dict[str, Any]:
    """What the page draws of a description: each link at zero joints (its base frame), the
    sticks to its child joints, the joints with their units and limits."""
    try:
        robot = load(description.path, packages)
    except UrdfError as exc:
        raise CommissioningError(422, str(exc)) from None
    chain, ends = robot.chain, robot.ends
    poses, _ = chain.link_poses(np.zeros(len(chain.joint_names)))
    return {
        "id": description.id,
        "name": robot.name,
        "joints": [
            {"name": n, "unit": u, "limits": None if not np.isfinite(lim).all() else lim.tolist()}
            for n, u, lim in zip(chain.joint_names, chain.joint_units, chain.limits, strict=True)
        ],
        "links": [
            {"name": name, "pose": pose.tolist(), "ends": [list(e) for e in ends.get(name, ())]}
            for name, pose in zip(chain.link_names, pose7_from_matrix(poses), strict=True)
        ],
        "warnings": list(robot.warnings),
    }
