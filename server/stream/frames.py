"""Turn one robot sample into the ``frame`` message, encoded once for every viewer."""

from __future__ import annotations

import time

import numpy as np
import orjson

from ..cell import Robot
from ..kinematics import pose7_from_matrix
from .types import Array, RobotSample

# orjson rather than json: it serialises numpy arrays directly and is ~10x
# faster, and this runs 50-100 times a second per robot.
_OPTS = orjson.OPT_SERIALIZE_NUMPY


def compute_frame(robot: Robot, sample: RobotSample) -> tuple[bytes, bool, str | None]:
    """Poses for ``sample`` encoded as a ``frame`` message; returns (bytes, ok, error)."""
    error = sample.error
    q: Array | None = None
    links: Array | list[object] = []
    tcp: Array | list[object] = []
    if error is None and sample.values is not None:
        q = sample.values * robot.to_si
        link_poses, tcp_pose, ok = robot.poses(q)
        if bool(ok):
            links = pose7_from_matrix(link_poses)
            tcp = links[-1] if robot.tcp_is_last_link else pose7_from_matrix(tcp_pose)
        else:
            error = f"unreachable posture: joints {np.round(sample.values, 3).tolist()}"
    message = {
        "type": "frame",
        "robot": robot.name,
        "seq": sample.seq,
        "t_source": sample.t_source,
        "t_sent": time.time(),
        "joints": q if q is not None else [],
        "links": links,
        "tcp": tcp,
        "ok": error is None,
        "error": error,
    }
    return orjson.dumps(message, option=_OPTS), error is None, error
