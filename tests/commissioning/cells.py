"""Cells for the commissioning tests, each robot on the embedded mock and held still.

``STILL``: an IndraMotion MLC Type 12 whose nodes read 10000 and 20000 (node
units, scale 0.001 deg), so every change to its mapping shows in
``/api/robots`` without the server's arithmetic. ``TODO_ARM``: a six-joint
Denavit-Hartenberg arm with no meshes and a ``TODO`` for its description, as
``discover`` leaves one for a transformation it knows. ``TODO_URDF_ARM``: the
same arm as ``discover`` leaves one for a transformation linkview cannot
compute: a URDF file that is not there.
"""

from __future__ import annotations

from pathlib import Path

SOURCE = """\
[[source]]
name = "line"
"""

STILL = """
[[robot]]
name = "still"   # held at one pose
source = "line"
kinematics = { type = "type12", limits = [[-40.0, 40.0], [-40.0, 40.0]] }
joints = [
    { node = "plc/app/Application/sym/PLC_PRG/a0", unit = "deg", scale = 0.001 },
    { node = "plc/app/Application/sym/PLC_PRG/a1", unit = "deg", scale = 0.001 },
]
demo_targets = [[10000.0, 20000.0]]
"""

ARM_JOINTS = """\
joints = [
    { node = "motion/axs/A1/state/values/actual/pos" },
    { node = "motion/axs/A2/state/values/actual/pos" },
    { node = "motion/axs/A3/state/values/actual/pos" },
    { node = "motion/axs/A4/state/values/actual/pos" },
    { node = "motion/axs/A5/state/values/actual/pos" },
    { node = "motion/axs/A6/state/values/actual/pos" },
]
"""

TODO_ARM = (
    """
# TODO: which URDF describes arm? linkview cannot compute its joint transformation.
[[robot]]
name = "arm"
source = "line"
base = { xyz = [1000.0, 0.0, 0.0], rpy_deg = [0.0, 0.0, 0.0] }
"""
    + ARM_JOINTS
    + """demo_targets = [[10.0, 20.0, 30.0, 40.0, 50.0, 60.0]]

[robot.kinematics]
type = "dh"
d = [300.0, 0.0, 0.0, 400.0, 0.0, 80.0]
a = [0.0, 400.0, 50.0, 0.0, 0.0, 0.0]
alpha_deg = [90.0, 0.0, 90.0, -90.0, 90.0, 0.0]
"""
)

TODO_URDF_ARM = (
    """
# Kinematics arm: joint transformation RobotArm6, axes A1, A2, A3, A4, A5, A6.
[[robot]]
name = "arm"
source = "line"
base = { xyz = [1000.0, 0.0, 0.0], rpy_deg = [0.0, 0.0, 0.0] }
# TODO: which URDF (or xacro) describes arm? linkview cannot compute the
# joint transformation RobotArm6.
kinematics = { type = "urdf", file = "arm.urdf" }
"""
    + ARM_JOINTS
)


def cell_file(folder: Path, text: str) -> Path:
    """``folder/cell.toml`` holding ``text``."""
    path = folder / "cell.toml"
    path.write_text(text)
    return path
