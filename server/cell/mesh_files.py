"""Mesh files served to the page as they are: each must be what it claims, where it claims.

A ``mesh_dir`` file is sent to every viewer byte for byte, so a cell folder
handed over by someone else must not be able to make the server send another
file: a symlink to ``/etc/passwd`` named ``link1.glb`` stays unserved. The file
must resolve inside its folder, be a regular file and begin with the GLB magic.
"""

from __future__ import annotations

from pathlib import Path

GLB_MAGIC = b"glTF"


def glb_problem(path: Path, folder: Path | None = None) -> str | None:
    """Why ``path`` may not be served as a GLB (from inside ``folder``), or None if it may."""
    try:
        resolved = path.resolve(strict=True)
        if folder is not None and not resolved.is_relative_to(folder.resolve()):
            return f"leads outside its folder {folder} (to {resolved})"
        if not resolved.is_file():
            return "is not a regular file"
        with resolved.open("rb") as file:
            head = file.read(len(GLB_MAGIC))
    except OSError as exc:
        return f"cannot be read ({exc.strerror or exc})"
    if head != GLB_MAGIC:
        return "is not a binary glTF file (it does not begin with 'glTF')"
    return None
