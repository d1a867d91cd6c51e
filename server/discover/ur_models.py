"""Universal Robots arms as linkview kinematics: UR's published Denavit-Hartenberg tables.

From Universal Robots' "Parameters for calculations of kinematics and dynamics"
(standard DH; d and a in metres there, mm here; alpha pi/2, 0, 0, pi/2, -pi/2,
0 on every model). RTDE's ``actual_q`` is in this table's joint order and
zero, so an arm drawn from it needs no offsets. The limits are those UR's
description package (ur_description) gives: +-360 deg, the elbow +-180 deg.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class UrModel:
    """One arm: its DH table (mm, deg) and joint limits (deg)."""

    name: str
    d_mm: tuple[float, ...]
    a_mm: tuple[float, ...]
    limits_deg: tuple[tuple[float, float], ...]
    alpha_deg: tuple[float, ...] = (90.0, 0.0, 0.0, 90.0, -90.0, 0.0)


_LIMITS = ((-360.0, 360.0), (-360.0, 360.0), (-180.0, 180.0), *((-360.0, 360.0),) * 3)


def _model(name: str, d_m: tuple[float, ...], a2_m: float, a3_m: float) -> UrModel:
    d = (d_m[0], 0.0, 0.0, d_m[1], d_m[2], d_m[3])
    return UrModel(
        name,
        tuple(round(x * 1000.0, 6) for x in d),
        (0.0, round(a2_m * 1000.0, 6), round(a3_m * 1000.0, 6), 0.0, 0.0, 0.0),
        _LIMITS,
    )


MODELS = {
    m.name: m
    for m in (
        _model("ur3e", (0.15185, 0.13105, 0.08535, 0.0921), -0.24355, -0.2132),
        _model("ur5e", (0.1625, 0.1333, 0.0997, 0.0996), -0.425, -0.3922),
        _model("ur10e", (0.1807, 0.17415, 0.11985, 0.11655), -0.6127, -0.57155),
        _model("ur16e", (0.1807, 0.17415, 0.11985, 0.11655), -0.4784, -0.36),
        _model("ur3", (0.1519, 0.11235, 0.08535, 0.0819), -0.24365, -0.21325),
        _model("ur5", (0.089159, 0.10915, 0.09465, 0.0823), -0.425, -0.39225),
        _model("ur10", (0.1273, 0.163941, 0.1157, 0.0922), -0.612, -0.5723),
    )
}
"""Every arm ``discover --model`` knows, by the name UR's description package uses."""
