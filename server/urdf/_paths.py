"""Files a robot description names: ``package://``, ``file://`` and plain paths.

ROS packages are found by ``server.sandbox.packages`` (as ROS would, without ROS).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from urllib.parse import unquote, urlparse

from ..sandbox.packages import PackageNotFound, Packages
from .model import UrdfError

__all__ = ["MESH_SUFFIXES", "Packages", "resolve_mesh"]

MESH_SUFFIXES = (".stl", ".obj", ".dae", ".glb", ".gltf", ".ply")


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
        except PackageNotFound as exc:
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
