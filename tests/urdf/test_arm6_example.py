"""The example arm6 robot: loads, converts, matches its mesh script, and solves its inverse."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import trimesh

from server.urdf import link_meshes, load_urdf

EXAMPLE = Path(__file__).parents[2] / "cells" / "examples" / "arm6"
DESCRIPTION = EXAMPLE / "arm6_description"
URDF = DESCRIPTION / "urdf" / "arm6.urdf"


def test_the_example_loads_with_its_package() -> None:
    robot = load_urdf(URDF, {"arm6_description": DESCRIPTION})
    assert robot.joint_names == (
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    )
    assert robot.link_names[0] == "base_link" and robot.chain.tip == "tool0"
    assert robot.joint_units == ("rad",) * 6
    assert np.all(robot.limits[:, 1] <= 2 * math.pi + 1e-12)
    # A UR5 at zero lies stretched out along +x, the wrist 2 housing pointing down.
    tool, _ = robot.chain.forward(np.zeros(6))
    np.testing.assert_allclose(
        tool[:3, 3],
        [0.425 + 0.39225, 0.13585 - 0.1197 + 0.093 + 0.0823, 0.089159 - 0.09465],
        atol=1e-12,
    )


def test_its_meshes_are_small_and_in_their_link_frames(tmp_path: Path) -> None:
    robot = load_urdf(URDF, {"arm6_description": DESCRIPTION})
    files = link_meshes(robot, tmp_path).files
    assert set(files) == set(robot.link_names) - {"tool0"}
    assert all(path.stat().st_size < 60_000 for path in files.values())
    upper = trimesh.load(files["upper_arm_link"], force="scene").bounds
    # The upper arm runs along its frame's z from the shoulder to the elbow (0.425 m).
    assert upper[0, 2] < 0.0 and 0.425 < upper[1, 2] < 0.5
    base = trimesh.load(files["base_link"], force="scene").bounds
    assert abs(base[0, 2]) < 1e-6 and base[1, 2] < 0.089159


def test_the_committed_stl_files_are_what_the_script_writes(tmp_path: Path) -> None:
    script = EXAMPLE / "build_meshes.py"
    subprocess.run(
        [sys.executable, str(script), "--out", str(tmp_path)],
        check=True,
        capture_output=True,
        timeout=120,
    )
    written = sorted(p.name for p in tmp_path.iterdir())
    assert written == sorted(p.name for p in (DESCRIPTION / "meshes").iterdir())
    for name in written:
        assert (tmp_path / name).read_bytes() == (DESCRIPTION / "meshes" / name).read_bytes(), name


def test_inverse_round_trips_on_the_example() -> None:
    chain = load_urdf(URDF, {"arm6_description": DESCRIPTION}).chain
    rng = np.random.default_rng(11)
    q_true = rng.uniform(-2.5, 2.5, (25, 6))
    targets, _ = chain.forward(q_true)
    q, ok = chain.inverse(targets, q_true + rng.normal(0, 0.3, q_true.shape))
    assert ok.all()
    np.testing.assert_allclose(chain.forward(q)[0], targets, atol=1e-9)
