"""The default demo cell, matching the axes the mock data layer simulates."""

from __future__ import annotations

from ..kinematics import Type12, iiwa7
from .axis_group import tilt_rotate_positioner
from .robot import Joint, Robot


def axis_node(axis: str) -> str:
    """Data-layer node of an axis's actual position."""
    return f"motion/axs/{axis}/state/values/actual/pos"


def kin12() -> Robot:
    """The seed 000 Type 12 mechanism, joints ``kin12_a0`` / ``kin12_a1`` in degrees."""
    kin = Type12()
    return Robot(
        name="kin12",
        family="type12",
        kinematics=kin,
        joints=(
            Joint("a0", axis_node("kin12_a0"), "deg"),
            Joint("a1", axis_node("kin12_a1"), "deg"),
        ),
        link_names=kin.link_names,
        base=(-0.75, 0.35, 0.0, 0.0, 0.0, 0.0, 1.0),
    )


def iiwa() -> Robot:
    """The KUKA LBR iiwa 7 R800 (standard DH), axes ``iiwa_a1`` ... ``iiwa_a7`` in degrees."""
    return Robot(
        name="iiwa7",
        family="dh",
        kinematics=iiwa7(),
        joints=tuple(Joint(f"a{i}", axis_node(f"iiwa_a{i}"), "deg") for i in range(1, 8)),
        link_names=tuple(f"link{i}" for i in range(8)),
        tcp_is_last_link=True,
    )


def positioner() -> Robot:
    """A tilt/rotate table built as a MotionPlus axis group; ``pos_tilt``/``pos_turn`` in deg."""
    return Robot(
        name="positioner",
        family="axis_group",
        kinematics=tilt_rotate_positioner(),
        joints=(
            Joint("tilt", axis_node("pos_tilt"), "deg"),
            Joint("turn", axis_node("pos_turn"), "deg"),
        ),
        link_names=("base", "tilt", "table"),
        base=(0.85, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
        tcp_is_last_link=True,
    )


def default_cell() -> list[Robot]:
    """Every robot of the demo cell."""
    return [kin12(), iiwa(), positioner()]
