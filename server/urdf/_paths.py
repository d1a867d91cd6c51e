"""Mesh references of a URDF resolved to files: ``package://``, ``file://`` and plain paths."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from urllib.parse import unquote, urlparse

from .model import UrdfError

MESH_SUFFIXES = (".stl", ".obj", ".dae")


def resolve_mesh(uri: str, link: str, urdf_dir: Path, packages: Mapping[str, Path]) -> Path:
    """The file that mesh ``uri`` of ``link`` names; UrdfError if it is unknown or missing.

    ``package://name/rest`` is ``packages[name] / rest``; ``file://`` URIs and
    absolute paths are taken as they are; relative paths are relative to the
    URDF's folder.
    """
    if uri.startswith("package://"):
        name, _, rest = uri[len("package://") :].partition("/")
        if name not in packages:
            given = ", ".join(sorted(packages)) or "none"
            raise UrdfError(
                f"link {link!r}: mesh {uri!r} is in package {name!r}, which is not among "
                f"the packages given (given: {given})"
            )
        path = Path(packages[name]) / rest
    elif uri.startswith("file://"):
        path = Path(unquote(urlparse(uri).path))
    elif "://" in uri:
        raise UrdfError(
            f"link {link!r}: mesh {uri!r}: only package://, file:// and file paths are supported"
        )
    else:
        path = Path(uri) if Path(uri).is_absolute() else urdf_dir / uri
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise UrdfError(
            f"link {link!r}: mesh {uri!r} has an unsupported format; use "
            + ", ".join(s[1:].upper() for s in MESH_SUFFIXES)
        )
    if not path.is_file():
        raise UrdfError(f"link {link!r}: mesh file {path} not found (from {uri!r})")
    return path
