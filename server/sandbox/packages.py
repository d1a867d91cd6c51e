"""ROS packages found as ROS would find them, without ROS (``package://``, ``$(find)``).

First among the folders the cell gives (``packages``), then by walking up from
the description file: a folder that is the package (by its name, or by the
``<name>`` in its ``package.xml``), or that holds one (a folder of that name,
or a sub-folder whose ``package.xml`` names it). So a description copied with
its package, or a workspace's ``src`` folder copied whole, needs no
``packages`` at all.

Here (not in ``server.urdf``) because the xacro worker process needs it too and
must start without the URDF reader's heavy imports.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from lxml import etree


class PackageNotFound(LookupError):
    """A ROS package neither the cell names nor the search finds; the message says where."""


def package_name(folder: Path) -> str | None:
    """The ``<name>`` of ``folder/package.xml``, or None if it has none."""
    manifest = folder / "package.xml"
    if not manifest.is_file():
        return None
    try:
        name = etree.parse(str(manifest)).getroot().findtext("name")
    except (OSError, etree.XMLSyntaxError):
        return None
    return name.strip() if name else None


def _search_up(name: str, start: Path) -> Path | None:
    for folder in (start, *start.parents):
        if folder.name == name or package_name(folder) == name:
            return folder
        if (folder / name).is_dir():
            return folder / name
        try:
            children = sorted(c for c in folder.iterdir() if c.is_dir())
        except OSError:
            continue
        for child in children:
            if package_name(child) == name:
                return child
    return None


class Packages:
    """Where ROS package names lead for one description file (see the module doc)."""

    def __init__(self, given: Mapping[str, Path], start: Path) -> None:
        self.given = {name: Path(folder) for name, folder in given.items()}
        self.start = start
        self._found: dict[str, Path | None] = {}

    def find(self, name: str) -> Path | None:
        """The folder of package ``name``, or None if neither the cell nor a search finds it."""
        if name in self.given:
            return self.given[name]
        if name not in self._found:
            self._found[name] = _search_up(name, self.start.resolve())
        return self._found[name]

    def learn(self, found: Mapping[str, Path]) -> None:
        """Take what another search (the xacro worker's) found, so it is not searched again."""
        for name, folder in found.items():
            if name not in self.given:
                self._found[name] = Path(folder)

    @property
    def found(self) -> dict[str, Path]:
        """Every package the search found so far (not those the cell gives)."""
        return {name: folder for name, folder in self._found.items() if folder is not None}

    def require(self, name: str) -> Path:
        """The folder of package ``name``; PackageNotFound saying where it was looked for."""
        found = self.find(name)
        if found is None:
            given = ", ".join(sorted(self.given)) or "none"
            raise PackageNotFound(
                f"package {name!r} not found: it is not among the cell's packages (given: "
                f"{given}), and no folder above {self.start} is it or holds it; add it to "
                "the robot's kinematics.packages"
            )
        return found
