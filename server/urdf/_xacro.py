"""xacro files expanded to URDF text with the ``xacro`` package from PyPI, without ROS.

``$(find pkg)`` (and ``find()`` inside ``$(eval ...)``) would ask ROS's package
index; here it asks ``Packages``, as ``package://`` does. xacro keeps its state
(file stack, arguments) in module globals, so one expansion runs at a time.
"""

from __future__ import annotations

import io
import threading
import xml.parsers.expat
from collections.abc import Mapping
from contextlib import redirect_stderr
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ._paths import Packages
from .model import UrdfError

XACRO_SUFFIX = ".xacro"
_LOCK = threading.Lock()


def is_xacro(path: Path) -> bool:
    """True for ``.xacro`` files (``.urdf.xacro`` included)."""
    return path.suffix.lower() == XACRO_SUFFIX


@dataclass(frozen=True)
class Expanded:
    """A xacro file's URDF text, the files it included, and what xacro warned about."""

    text: str
    """As the ``xacro`` command prints it, so line numbers match its output."""
    included: tuple[Path, ...]
    warnings: tuple[str, ...]


def expand(path: Path, args: Mapping[str, str], packages: Packages) -> Expanded:
    """What xacro file ``path`` expands to with ``args``.

    UrdfError names the file xacro was reading when it failed and xacro's own
    message (which gives the line for malformed XML).
    """
    import xacro
    from xacro import substitution_args

    sub: Any = substitution_args

    def find(name: str) -> str:
        try:
            return str(packages.require(name))
        except UrdfError as exc:
            raise UrdfError(f"$(find {name}): {exc}") from None

    if not path.is_file():
        raise UrdfError(f"xacro file {path} not found")
    stderr = io.StringIO()
    with _LOCK:
        saved = sub._eval_find, sub._eval_dict["find"]
        sub._eval_find = sub._eval_dict["find"] = find
        xacro.all_includes = []
        try:
            with redirect_stderr(stderr):
                doc = xacro.process_file(str(path), mappings={k: str(v) for k, v in args.items()})
            text = str(doc.toprettyxml(indent="  "))
            included = tuple(Path(name) for name in dict.fromkeys(xacro.all_includes))
        except Exception as exc:  # xacro evaluates the file's expressions: any error is the file's
            where = (xacro.filestack or [None])[-1] or path
            kind = "malformed XML" if isinstance(exc, xml.parsers.expat.ExpatError) else "xacro"
            inner = getattr(exc, "exc", None)  # xacro wraps what $(find) raised
            reason = inner if isinstance(inner, UrdfError) else exc
            raise UrdfError(f"{where}: {kind}: {reason}") from None
        finally:
            sub._eval_find, sub._eval_dict["find"] = saved
    warnings = [f"{path}: xacro: {line}" for line in stderr.getvalue().splitlines() if line.strip()]
    return Expanded(text, included, tuple(warnings))
