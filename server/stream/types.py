"""Values passed between the acquisition loop and the frame encoder."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class RobotSample:
    """One read of a robot's joints, in data-layer units, or why it failed."""

    seq: int
    t_source: float
    """Unix time (s) the data layer sampled the values."""
    values: Array | None
    error: str | None = None
    setpoints: Array | None = None
    """The joints' setpoint values (data-layer units) where the robot has setpoint nodes."""
