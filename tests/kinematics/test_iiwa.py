"""KUKA LBR iiwa 7: the DH table, seed 004's eight-configuration inverse and its quality pick."""

from __future__ import annotations

import math

import numpy as np
import pytest
import roboticstoolbox as rtb
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from server.kinematics import IiwaSolutions, iiwa7

ROBOT = iiwa7()
LIMITS_DEG = [170, 120, 170, 120, 170, 120, 175]
# The iiwa 7 R800 as published, built independently of the module.
RTB_IIWA = rtb.DHRobot(
    [
        rtb.RevoluteDH(d=d, alpha=math.radians(alpha))
        for d, alpha in zip(
            [0.34, 0.0, 0.40, 0.0, 0.40, 0.0, 0.126], [-90, 90, 90, -90, -90, 90, 0], strict=True
        )
    ]
)
joint = [st.floats(-math.radians(lim), math.radians(lim)) for lim in LIMITS_DEG]
configuration = st.tuples(*joint).map(np.array)


def wrap(angle: np.ndarray) -> np.ndarray:
    return np.remainder(np.asarray(angle) + math.pi, 2 * math.pi) - math.pi


def rtb_flange(q: np.ndarray) -> np.ndarray:
    return np.asarray(RTB_IIWA.ets().eval(q))


def test_table_and_limits_are_the_iiwa_7_r800() -> None:
    params = ROBOT.params()
    assert params["convention"] == "standard"
    np.testing.assert_allclose(params["d"], [0.34, 0, 0.40, 0, 0.40, 0, 0.126])
    np.testing.assert_allclose(params["a"], np.zeros(7))
    np.testing.assert_allclose(np.degrees(params["alpha"]), [-90, 90, 90, -90, -90, 90, 0])
    np.testing.assert_allclose(
        np.degrees(params["limits"]), np.stack([-np.array(LIMITS_DEG), LIMITS_DEG], axis=-1)
    )


def test_flange_at_zero_joints_is_1_266_m_straight_up() -> None:
    pose, ok = ROBOT.forward(np.zeros(7))
    assert ok
    np.testing.assert_allclose(
        pose, [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 1.266], [0, 0, 0, 1]], atol=1e-15
    )


def test_link_frames_agree_with_roboticstoolbox() -> None:
    q = np.random.default_rng(0).uniform(-3, 3, (20, 7))
    frames, _ = ROBOT.link_poses(q)
    for row in range(20):
        expected = np.array([f.A for f in RTB_IIWA.fkine_all(q[row])])
        np.testing.assert_allclose(frames[row], expected, rtol=0, atol=1e-12)


@settings(max_examples=150, deadline=None)
@given(configuration)
@example(np.zeros(7))  # wrist on the base axis, elbow and wrist straight
@example(np.array([0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]))  # arm stretched sideways
def test_every_reached_configuration_reproduces_the_pose(q) -> None:
    frames, _ = ROBOT.link_poses(q)
    wrist_off_axis = math.hypot(frames[5, 0, 3], frames[5, 1, 3])
    # A straight elbow with the wrist centre on the base axis leaves joints 1 and 4
    # resting on square roots of rounding errors: no configuration may reach 1e-9 there.
    assume(abs(math.sin(q[3])) > 1e-6 or wrist_off_axis > 1e-6 or q[2] == 0.0)
    pose = frames[-1]
    sol = ROBOT.inverse_all(pose, q[2])
    assert isinstance(sol, IiwaSolutions)
    assert sol.q.shape == (8, 7) and sol.reached.shape == sol.within_limits.shape == (8,)
    assert sol.reached.any()
    assert np.all(np.abs(sol.q) <= math.pi)
    np.testing.assert_allclose(sol.q[:, 2], wrap(q[2]), atol=1e-15)  # joint 3 held
    reached = sol.q[sol.reached]
    error = np.abs(rtb_flange(reached) - pose).max(axis=(-1, -2))
    assert error.max() < 1e-9


@settings(max_examples=150, deadline=None)
@given(configuration)
def test_the_starting_configuration_is_among_the_eight(q) -> None:
    # Off the elbow and wrist singularities, the eight are distinct and one is q.
    assume(abs(math.sin(q[3])) > 1e-3 and abs(math.sin(q[5])) > 1e-3)
    pose, _ = ROBOT.forward(q)
    sol = ROBOT.inverse_all(pose, q[2])
    distance = np.abs(wrap(sol.q - q)).max(axis=-1)
    assert distance.min() < 1e-7
    assert sol.reached[np.argmin(distance)]
    margin = np.min(np.abs(np.abs(q) - np.radians(LIMITS_DEG)))
    if margin > 1e-9:  # on a limit itself, rounding decides
        assert sol.within_limits[np.argmin(distance)]


def test_configurations_follow_the_arm_elbow_wrist_numbering() -> None:
    q = np.radians([20.0, 40.0, 10.0, 60.0, -30.0, 50.0, 15.0])
    sol = ROBOT.inverse_all(ROBOT.forward(q)[0], q[2])
    elbow_sign = np.sign(sol.q[:, 3])
    wrist_sign = np.sign(sol.q[:, 5])
    np.testing.assert_array_equal(elbow_sign, [1, 1, -1, -1, 1, 1, -1, -1])
    np.testing.assert_array_equal(wrist_sign, [1, -1, 1, -1, 1, -1, 1, -1])
    # Flipping the wrist turns joints 5 and 7 by half a turn and keeps 1-4.
    np.testing.assert_allclose(sol.q[0::2, :4], sol.q[1::2, :4], atol=1e-12)
    np.testing.assert_allclose(
        np.abs(wrap(sol.q[0::2, [4, 6]] - sol.q[1::2, [4, 6]])), math.pi, atol=1e-9
    )


def test_singular_wrist_shares_the_turn_between_joints_5_and_7() -> None:
    q = np.array([0.3, 0.5, -0.2, 1.0, 0.4, 0.0, 0.6])  # joint 6 at zero
    pose, _ = ROBOT.forward(q)
    sol = ROBOT.inverse_all(pose, q[2])
    assert sol.reached.all()
    # The seed gives joints 5 and 7 half of their sum each, + pi each on the flipped wrist.
    straight = sol.q[0]
    assert abs(straight[5]) < 1e-12
    np.testing.assert_allclose(straight[4], straight[6], atol=1e-12)
    np.testing.assert_allclose(straight[4], 0.5 * (q[4] + q[6]), atol=1e-9)


def test_batches_of_poses_and_held_joints_broadcast() -> None:
    rng = np.random.default_rng(4)
    q = rng.uniform(-1, 1, (3, 5, 7))
    pose, _ = ROBOT.forward(q)
    sol = ROBOT.inverse_all(pose, q[..., 2])
    assert sol.q.shape == (3, 5, 8, 7) and sol.reached.shape == (3, 5, 8)
    assert sol.reached.any(axis=-1).all()
    single = ROBOT.inverse_all(pose[1, 2], q[1, 2, 2])
    np.testing.assert_array_equal(single.q, sol.q[1, 2])


def test_unreachable_poses_reach_nothing_and_stay_finite() -> None:
    far = np.eye(4)
    far[:3, 3] = [2.0, 0.0, 0.5]  # beyond the 0.8 m shoulder-to-wrist reach
    sol = ROBOT.inverse_all(np.stack([far, np.full((4, 4), np.nan)]), 0.0)
    assert not sol.reached.any()
    q, ok = ROBOT.inverse(far, np.zeros(7))
    assert not ok and np.isfinite(q).all()


@settings(max_examples=60, deadline=None)
@given(configuration, configuration)
def test_inverse_picks_the_reachable_configuration_nearest_the_reference(q, q_ref) -> None:
    pose, _ = ROBOT.forward(q)
    q_sol, ok = ROBOT.inverse(pose, q_ref)
    sol = ROBOT.inverse_all(pose, q_ref[2])
    usable = sol.reached & sol.within_limits
    if usable.any():  # the seed's quality function over the analytic solutions
        assert ok
        cost = np.abs(sol.q - wrap(q_ref)).sum(axis=-1)
        assert np.abs(q_sol - wrap(q_ref)).sum() == pytest.approx(cost[usable].min(), abs=1e-12)
        assert q_sol[2] == pytest.approx(wrap(q_ref[2]), abs=1e-15)
    # Otherwise the numerical fallback may fail: hypothesis likes joints exactly on a
    # limit, where the solutions within limits can shrink to a point.
    if ok:
        assert ROBOT.within_limits(q_sol)
        np.testing.assert_allclose(rtb_flange(q_sol), pose, atol=1e-9)


def test_inverse_falls_back_to_the_numerical_solver() -> None:
    rng = np.random.default_rng(5)
    lim = ROBOT.joint_limits()
    q, q_ref = rng.uniform(lim[:, 0], lim[:, 1], (2, 300, 7))
    pose, _ = ROBOT.forward(q)
    sol = ROBOT.inverse_all(pose, q_ref[:, 2])
    no_analytic = ~(sol.reached & sol.within_limits).any(axis=-1)
    assert no_analytic.sum() >= 10  # with joint 3 held elsewhere, some poses need it free
    q_sol, ok = ROBOT.inverse(pose[no_analytic], q_ref[no_analytic])
    assert ok.mean() >= 0.99
    np.testing.assert_allclose(rtb_flange(q_sol[ok]), pose[no_analytic][ok], atol=1e-9)
    assert ROBOT.within_limits(q_sol[ok]).all()


def test_inverse_returns_the_reference_when_it_is_a_solution() -> None:
    q = np.radians([-50.0, 30.0, 25.0, -80.0, 110.0, -45.0, 160.0])
    q_sol, ok = ROBOT.inverse(ROBOT.forward(q)[0], q)
    assert ok
    np.testing.assert_allclose(q_sol, q, atol=1e-9)
