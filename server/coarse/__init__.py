"""Coarse link meshes for the page's 2D view: decimated once per file content, kept in memory.

``decimate`` turns a link's GLB into one with a few hundred triangles and flat
colours (manifold3d, or fast-simplification through trimesh); ``cache`` converts each file's
content once, in a worker thread, and serves it from memory after that.
"""

from __future__ import annotations

from .cache import CoarseMeshes
from .decimate import LINK_FACES, TOLERANCE, CoarseError, coarse_glb

__all__ = ["LINK_FACES", "TOLERANCE", "CoarseError", "CoarseMeshes", "coarse_glb"]
