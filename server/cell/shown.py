"""Texts about a cell as viewers see them: file paths relative to the cell's folder.

A warning or error names the files it is about; shown on a page or in
/api/health, an absolute path tells every viewer where the server keeps its
files (a home folder, a user name). Relative to the cell file's folder they
still say which file is meant to the person who has that folder.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

_ABSOLUTE = re.compile(r"(?<![\w:/.~-])(/[^\s'\"(),;]+)")
"""An absolute path in running text, not a URL's path (``http://host/x``) or a route's."""


def relative_paths(text: str, folder: Path | None) -> str:
    """``text`` with each absolute path inside ``folder``, or in a folder that exists on
    disk, made relative to ``folder``."""
    if folder is None:
        return text

    inside = str(folder).rstrip("/") + "/"

    def relative(match: re.Match[str]) -> str:
        path = match[1].rstrip(".:")
        known = path.startswith(inside) or os.path.isdir(os.path.dirname(path))
        if not known:
            return match[1]  # not a file of ours: a route, a node path, ...
        return os.path.relpath(path, folder) + match[1][len(path) :]

    return _ABSOLUTE.sub(relative, text)
