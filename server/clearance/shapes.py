"""Collision shapes of a robot's links: the convex hull of each link's mesh, in the link frame."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import trimesh

from ..cell import Robot

log = logging.getLogger(__name__)


MAX_HULL_POINTS = 20_000
"""Vertices a link's hull is computed from; a finer mesh is thinned to this many first."""
MAX_HULL_VERTICES = 256
"""Vertices of a hull the checker keeps; a rounder hull is computed again from fewer points."""


def _thinned(points: np.ndarray, count: int) -> np.ndarray:
    """``count`` of ``points`` spread over the array, plus the extremes along each axis."""
    if len(points) <= count:
        return points
    picked = points[np.linspace(0, len(points) - 1, count).astype(np.intp)]
    extremes = points[np.concatenate([points.argmin(axis=0), points.argmax(axis=0)])]
    return np.concatenate([picked, extremes])


def _hull(path: Path) -> trimesh.Trimesh | None:
    scene = trimesh.load(path, force="scene")
    mesh = scene.to_geometry() if isinstance(scene, trimesh.Scene) else scene
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.vertices) < 4:
        return None
    # The hull, not the mesh: tens of vertices instead of thousands keep a check of the
    # demo cell near a millisecond, and as the hull holds the mesh, a distance between
    # hulls never says two links are further apart than they are. A mesh of hundreds of
    # thousands of vertices (a scanned part) is thinned first, and a round hull decimated
    # to its MAX_HULL_VERTICES points spread over it: cost and memory stay bounded (two
    # 200 000-vertex meshes held 950 MB and stalled viewers); such a hull may lie up to
    # the spacing of the dropped points inside the mesh.
    points = _thinned(np.asarray(mesh.vertices), MAX_HULL_POINTS)
    hull: trimesh.Trimesh = trimesh.convex.convex_hull(points)
    if len(hull.vertices) > MAX_HULL_VERTICES:
        hull = trimesh.convex.convex_hull(_thinned(np.asarray(hull.vertices), MAX_HULL_VERTICES))
    return hull


def link_shapes(robot: Robot) -> tuple[trimesh.Trimesh | None, ...]:
    """Per link of ``robot``, its collision shape (link frame, m), None where it has no mesh."""
    shapes = []
    for link, path in enumerate(robot.meshes):
        shape = None
        if path is not None:
            try:
                shape = _hull(path)
            except Exception as exc:  # a mesh the page draws as a stand-in: skipped here too
                log.warning("clearance: robot %s link %d: %s", robot.name, link, exc)
        shapes.append(shape)
    return tuple(shapes)
