"""Names of inverse solutions: the iiwa's eight configurations by flag, others as solved."""

from __future__ import annotations

import numpy as np
import pytest

from server.kinematics import DHChain, Type12, configuration_names, iiwa7
from server.kinematics.configurations import NUMERICAL, TYPE12_BRANCHES

ROBOT = iiwa7()


@pytest.mark.parametrize("seed", range(5))
def test_the_iiwas_eight_configurations_have_eight_names_true_to_their_joints(seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1.2, 1.2, 7)
    pose, _ = ROBOT.forward(q)
    found = ROBOT.inverse_all(pose, q[2])
    assert found.reached.all()  # a general pose: all eight exist
    names = configuration_names(ROBOT, found.q)
    assert len(set(names)) == 8
    for k, (row, name) in enumerate(zip(found.q, names, strict=True)):
        arm, elbow, wrist = k // 4, (k // 2) % 2, k % 2  # inverse_all's order
        # The flags read off the joints are the ones the inverse built them with ...
        assert ROBOT.configuration_flags(row).tolist() == [arm, elbow, wrist]
        # ... and the name says them: joint 4's and joint 6's signs, the shoulder's side.
        assert ("elbow −" in name) == (row[3] < 0) == bool(elbow)
        assert ("wrist flip" in name) == (row[5] < 0) == bool(wrist)
        assert name.startswith("shoulder back" if arm else "shoulder front")


def test_the_shoulder_flag_says_where_the_wrist_centre_is() -> None:
    # Joint 1 at 0, arm leaning forward (+x): wrist centre ahead; joint 2 negative: behind.
    ahead = [0.0, 0.6, 0.0, -0.8, 0.0, 0.5, 0.0]
    behind = [0.0, -0.6, 0.0, 0.8, 0.0, 0.5, 0.0]
    for q, expected in ((ahead, 0), (behind, 1)):
        pose, _ = ROBOT.forward(np.array(q))
        wrist_x = pose[0, 3] - 0.126 * pose[0, 2]
        assert (wrist_x < 0) == bool(expected)
        assert ROBOT.configuration_flags(q)[0] == expected


def test_other_families_are_named_as_their_solver_finds_them() -> None:
    q = np.zeros((3, 2))
    assert configuration_names(Type12(), q) == [TYPE12_BRANCHES] * 3
    chain = DHChain(d=[0.1, 0.0], a=[0.3, 0.2], alpha=[0.0, 0.0])
    assert configuration_names(chain, q) == [NUMERICAL] * 3
