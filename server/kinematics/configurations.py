"""Names of inverse-kinematics solutions that a person can tell apart ("shoulder front · ...").

Pure: a name comes from the kinematics and the joints (rad or m) alone. Only
what is true of the solver that found a solution is said: the KUKA LBR iiwa's
analytic inverse has eight named configurations; the IndraMotion MLC kinematic
Type 12 has the one pair of branches its note's inverse picks; every other
family is solved numerically from the current pose, with no branch to name.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .dh import LBRiiwa
from .type12 import Type12

_IIWA_FLAGS = (
    ("shoulder front", "shoulder back"),  # wrist centre ahead of / behind joint 1
    ("elbow +", "elbow −"),  # joint 4's sign
    ("wrist no-flip", "wrist flip"),  # joint 6's sign
)
TYPE12_BRANCHES = "L1–L2 right-hand · L5–L4 left-hand"
"""The branches of the circle intersections that Type 12's inverse takes (as its note does)."""
NUMERICAL = "numerical solution"
"""A solution of a numerical solver: the nearest to the current pose it converged to."""
SEPARATOR = " · "


def configuration_names(kinematics: object, q: npt.ArrayLike) -> list[str]:
    """A name for each joint row of ``q`` ``(b, n)`` (SI) solving ``kinematics``."""
    rows = np.atleast_2d(np.asarray(q, dtype=np.float64))
    if isinstance(kinematics, LBRiiwa):
        flags = kinematics.configuration_flags(rows)
        return [
            SEPARATOR.join(names[flag] for names, flag in zip(_IIWA_FLAGS, row, strict=True))
            for row in flags.tolist()
        ]
    name = TYPE12_BRANCHES if isinstance(kinematics, Type12) else NUMERICAL
    return [name] * len(rows)


__all__ = ["NUMERICAL", "TYPE12_BRANCHES", "configuration_names"]
