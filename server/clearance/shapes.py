"""Collision shapes of a robot's links: the convex hull of each link's mesh, in the link frame."""

from __future__ import annotations

import logging
from pathlib import Path

import trimesh

from ..cell import Robot

log = logging.getLogger(__name__)


def _hull(path: Path) -> trimesh.Trimesh | None:
    scene = trimesh.load(path, force="scene")
    mesh = scene.to_geometry() if isinstance(scene, trimesh.Scene) else scene
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.vertices) < 4:
        return None
    # The hull, not the mesh: tens of vertices instead of thousands keep a check of the
    # demo cell near a millisecond, and as the hull holds the mesh, a distance between
    # hulls never says two links are further apart than they are.
    hull: trimesh.Trimesh = mesh.convex_hull
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
