"""The clearance check running beside the stream: 10 times a second on the newest joint values,
while some viewer has asked for it (``POST /api/clearance``)."""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Mapping

import numpy as np
import numpy.typing as npt

from ..cell import Robot
from ..kinematics import matrix_from_pose7
from ..protocol import Clearance, NearLinks
from ..stream import Hub, Message
from .checker import ClearanceChecker, Near
from .shapes import link_shapes

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]
CLEARANCE_KEY = "clearance"
PERIOD_S = 0.1
RESEND_S = 1.0
"""The result is sent when it changes (to the millimetre), and at least this often."""
WANTED_S = 10.0
"""A page that wants clearance says so at least this often (``want``); nobody asking,
nothing is measured: the meshes are not even read."""


def _world_links(robot: Robot, values: Array) -> Array | None:
    links, _, ok = robot.poses(robot.to_si(values))
    if not bool(np.all(ok)):
        return None
    world: Array = matrix_from_pose7(np.asarray(robot.base, dtype=np.float64)) @ links
    return world


class ClearanceService:
    """Measures the robots of the running cell and publishes the result to every viewer."""

    def __init__(self, hub: Hub, within_m: float) -> None:
        self.hub = hub
        self.within_m = within_m
        self.checks = 0
        """Checks done; each one measures every robot pair near enough."""
        self.seconds = 0.0
        """Time spent in those checks (CPU of a worker thread)."""
        self.last: Clearance | None = None
        self._checker: ClearanceChecker | None = None
        self._robots: tuple[Robot, ...] = ()
        self._wanted_until = 0.0

    def want(self) -> None:
        """A viewer shows clearance: measure for the next ``WANTED_S``."""
        self._wanted_until = time.monotonic() + WANTED_S

    @property
    def wanted(self) -> bool:
        """Whether some viewer asked for clearance within ``WANTED_S``."""
        return time.monotonic() < self._wanted_until

    async def run(
        self,
        robots: Callable[[], tuple[Robot, ...]],
        values: Callable[[], Mapping[str, Array | None]],
    ) -> None:
        """Check every ``PERIOD_S``: ``robots()`` gives the robots, ``values()`` their values."""
        sent_at, sent = 0.0, None
        while True:
            await asyncio.sleep(PERIOD_S)
            if not self.wanted:
                sent = None  # whoever asks next gets the result at once
                continue
            try:
                result = await asyncio.to_thread(self.measure, robots(), dict(values()))
            except Exception:  # a bug here must never touch the stream
                log.exception("clearance: check failed")
                continue
            key = [(n.robots, n.links, round(n.distance_m, 3)) for n in result.near]
            if key != sent or time.monotonic() - sent_at >= RESEND_S:
                sent, sent_at = key, time.monotonic()
                self.hub.publish(CLEARANCE_KEY, Message(result.model_dump_json()))

    def measure(self, cell: tuple[Robot, ...], values: Mapping[str, Array | None]) -> Clearance:
        """The clearance of ``cell``'s robots at joint ``values`` (node units, by robot name)."""
        start = time.perf_counter()
        if self._checker is None or cell is not self._robots:  # a new cell: read its meshes
            self._checker, self._robots = _checker_of(cell), cell
        checker = self._checker
        by_name = {robot.name: robot for robot in cell}
        world = {}
        for name in checker.robots:
            read = values.get(name)
            poses = None if read is None else _world_links(by_name[name], read)
            if poses is not None:
                world[name] = poses
        near = sorted(checker.check(world, self.within_m), key=lambda n: n.distance_m)
        self.last = Clearance(
            type="clearance",
            within_m=self.within_m,
            robots=list(world),
            near=[_wire(n, by_name) for n in near],
        )
        self.checks += 1
        self.seconds += time.perf_counter() - start
        return self.last


def _checker_of(cell: tuple[Robot, ...]) -> ClearanceChecker:
    return ClearanceChecker({robot.name: link_shapes(robot) for robot in cell})


def _wire(near: Near, robots: Mapping[str, Robot]) -> NearLinks:
    names = (
        robots[near.robot_a].link_names[near.link_a],
        robots[near.robot_b].link_names[near.link_b],
    )
    return NearLinks(
        robots=(near.robot_a, near.robot_b),
        links=(near.link_a, near.link_b),
        link_names=names,
        distance_m=near.distance_m,
    )
