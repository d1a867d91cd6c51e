"""Files a robot description names: ``package://``, ``$(find)``, ``file://`` and plain paths.

A ROS package is found as ROS would find it, without ROS: first among the
folders the cell gives (``packages``), then by walking up from the description
file: a folder that is the package (by its name, or by the ``<name>`` in its
``package.xml``), or that holds one (a folder of that name, or a sub-folder whose
``package.xml`` names it). So a description copied with its package, or a
workspace's ``src`` folder copied whole, needs no ``packages`` at all.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from urllib.parse import unquote, urlparse

from lxml import etree

from .model import UrdfError

MESH_SUFFIXES = (".stl", ".obj", ".dae", ".glb", ".gltf", ".ply")


def _package_name(folder: Path) -> str | None:
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
        if folder.name == name or _package_name(folder) == name:
            return folder
        if (folder / name).is_dir():
            return folder / name
        try:
            children = sorted(c for c in folder.iterdir() if c.is_dir())
        except OSError:
            continue
        for child in children:
            if _package_name(child) == name:
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

    def require(self, name: str) -> Path:
        """The folder of package ``name``; UrdfError saying where it was looked for."""
        found = self.find(name)
        if found is None:
            given = ", ".join(sorted(self.given)) or "none"
            raise UrdfError(
                f"package {name!r} not found: it is not among the cell's packages (given: "
                f"{given}), and no folder above {self.start} is it or holds it; add it to "
                "the robot's kinematics.packages"
            )
        return found


def resolve_mesh(uri: str, link: str, folders: Sequence[Path], packages: Packages) -> Path:
    """The file that mesh ``uri`` of ``link`` names; UrdfError if it is unknown or missing.

    ``package://name/rest`` is ``rest`` in package ``name``; ``file://`` URIs and
    absolute paths are taken as they are; relative paths are relative to the
    first of ``folders`` (the description's, then those of the files it
    includes) that has the file.
    """
    if uri.startswith("package://"):
        # "package:///pkg/rest" (an empty host, as pinocchio's data writes it) means
        # the same as "package://pkg/rest" to ROS's package-path search.
        name, _, rest = uri[len("package://") :].lstrip("/").partition("/")
        try:
            path = packages.require(name) / rest
        except UrdfError as exc:
            raise UrdfError(f"link {link!r}: mesh {uri!r}: {exc}") from None
    elif uri.startswith("file://"):
        path = Path(unquote(urlparse(uri).path))
    elif "://" in uri:
        raise UrdfError(
            f"link {link!r}: mesh {uri!r}: only package://, file:// and file paths are supported"
        )
    elif Path(uri).is_absolute():
        path = Path(uri)
    else:
        found = [folder / uri for folder in folders if (folder / uri).is_file()]
        path = found[0] if found else folders[0] / uri
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise UrdfError(
            f"link {link!r}: mesh {uri!r} has an unsupported format; use "
            + ", ".join(s[1:].upper() for s in MESH_SUFFIXES)
        )
    if not path.is_file():
        raise UrdfError(f"link {link!r}: mesh file {path} not found (from {uri!r})")
    return path
