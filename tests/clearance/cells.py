"""Cells for the clearance tests: two KUKA LBR iiwa arms (the demo's meshes) side by side."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

ARM = """
[[robot]]
name = "{name}"
source = "mock"
base = {{ xyz = [{x_mm}, 0.0, 0.0] }}
joints = [{joints}]
mesh_dir = "{meshes}"
demo_targets = [[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]]

[robot.kinematics]
type = "dh"
convention = "standard"
solver = "iiwa"
d = [340.0, 0.0, 400.0, 0.0, 400.0, 0.0, 126.0]
a = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
alpha_deg = [-90.0, 90.0, 90.0, -90.0, -90.0, 90.0, 0.0]
limits = [[-170.0, 170.0], [-120.0, 120.0], [-170.0, 170.0], [-120.0, 120.0],
          [-170.0, 170.0], [-120.0, 120.0], [-175.0, 175.0]]
"""

BASE_RADIUS_M = 0.11
"""The iiwa's link0 (its base): 0.11 m around its axis, the widest of its links."""


def two_arms(folder: Path, apart_m: float) -> Path:
    """A cell file in ``folder``: arms "left" at x = 0 and "right" at ``apart_m``, both upright."""
    parts = ['[[source]]\nname = "mock"\n']
    for name, x in (("left", 0.0), ("right", apart_m * 1000.0)):
        joints = ", ".join(
            f'{{ node = "motion/axs/{name}_a{k}/state/values/actual/pos", unit = "deg" }}'
            for k in range(1, 8)
        )
        meshes = ROOT / "assets" / "iiwa7"
        parts.append(ARM.format(name=name, x_mm=x, joints=joints, meshes=meshes))
    path = folder / "two_arms.toml"
    path.write_text("\n".join(parts))
    return path
