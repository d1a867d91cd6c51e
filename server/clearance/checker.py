"""The closest links of different robots, with python-fcl through trimesh's CollisionManager.

Every robot has a manager of its own, so only pairs of links of different robots
are measured (a robot's neighbouring links always touch). A robot pair is only
measured when the boxes around the two robots, widened by the distance of
interest, overlap: a plant of many robots costs little more than its near pairs.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import trimesh

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Near:
    """Two links of different robots within the distance of interest (0 m: touching)."""

    robot_a: str
    link_a: int
    robot_b: str
    link_b: int
    distance_m: float


class _RobotShapes:
    def __init__(self, name: str, shapes: Sequence[trimesh.Trimesh | None]) -> None:
        self.name = name
        present = [(i, shape) for i, shape in enumerate(shapes) if shape is not None]
        self.links = [i for i, _ in present]
        self.vertices = [np.asarray(shape.vertices, dtype=np.float64) for _, shape in present]
        self.manager = trimesh.collision.CollisionManager()
        for i, shape in present:
            self.manager.add_object(str(i), shape)

    def place(self, world_links: Array) -> tuple[Array, Array]:
        """Move every shape to its world pose; the box around them all (lo, hi)."""
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for i, vertices in zip(self.links, self.vertices, strict=True):
            pose = world_links[i]
            self.manager.set_transform(str(i), pose)
            moved = vertices @ pose[:3, :3].T + pose[:3, 3]
            lo, hi = np.minimum(lo, moved.min(axis=0)), np.maximum(hi, moved.max(axis=0))
        return lo, hi


class ClearanceChecker:
    """Measures the robots given at construction; ``check`` takes their link poses each time."""

    def __init__(self, shapes: Mapping[str, Sequence[trimesh.Trimesh | None]]) -> None:
        self._robots = {
            name: _RobotShapes(name, robot) for name, robot in shapes.items() if any(robot)
        }

    @property
    def robots(self) -> tuple[str, ...]:
        """The robots that have at least one shape to measure."""
        return tuple(self._robots)

    def check(self, world_links: Mapping[str, Array], within_m: float) -> list[Near]:
        """For each pair of robots closer than ``within_m``: its closest links and their distance.

        ``world_links`` maps a robot's name to its link poses ``(n, 4, 4)`` in the
        world frame (m); robots left out (no pose now) are not measured.
        """
        boxes = {
            name: robot.place(world_links[name])
            for name, robot in self._robots.items()
            if name in world_links
        }
        near = []
        for a, b in itertools.combinations(boxes, 2):
            (lo_a, hi_a), (lo_b, hi_b) = boxes[a], boxes[b]
            if np.any(lo_a - within_m > hi_b) or np.any(lo_b - within_m > hi_a):
                continue
            first, second = self._robots[a].manager, self._robots[b].manager
            hit, names = first.in_collision_other(second, return_names=True)
            if hit:
                link_a, link_b = min(names, key=lambda pair: (int(pair[0]), int(pair[1])))
                distance = 0.0
            else:
                distance, (link_a, link_b) = first.min_distance_other(second, return_names=True)
            if distance <= within_m:
                near.append(Near(a, int(link_a), b, int(link_b), float(distance)))
        return near
