"""DHChain: agreement with roboticstoolbox and with seed 004's matrix, round trips, edge cases."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import roboticstoolbox as rtb
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from server.kinematics import DHChain

N_JOINTS = 7
length = st.floats(-0.6, 0.6, allow_nan=False)
angle = st.floats(-math.pi, math.pi, allow_nan=False)
# Alphas of real arms are multiples of 90 degrees; mix those with arbitrary ones.
alpha = st.one_of(st.sampled_from([0.0, math.pi / 2, -math.pi / 2, math.pi]), angle)
table = st.tuples(
    *(st.lists(s, min_size=N_JOINTS, max_size=N_JOINTS) for s in (length, length, alpha, angle))
)
conventions = st.sampled_from(["standard", "modified"])

# A 6-axis arm with offsets, both kinds of lengths and a modified-convention twin below.
PUMA_LIKE = {
    "d": [0.3, 0.0, 0.12, 0.43, 0.0, 0.08],
    "a": [0.0, 0.43, 0.02, 0.0, 0.0, 0.0],
    "alpha": [math.pi / 2, 0.0, -math.pi / 2, math.pi / 2, -math.pi / 2, 0.0],
    "theta_offset": [0.0, -math.pi / 2, 0.0, 0.0, 0.0, math.pi],
    "limits": np.radians(
        [[-160, 160], [-110, 110], [-135, 135], [-266, 266], [-100, 100], [-266, 266]]
    ),
}


def rtb_robot(d, a, alpha, offset, convention: str) -> rtb.DHRobot:
    link = rtb.RevoluteDH if convention == "standard" else rtb.RevoluteMDH
    return rtb.DHRobot(
        [link(d=d[i], a=a[i], alpha=alpha[i], offset=offset[i]) for i in range(len(d))]
    )


def rtb_all_frames(robot: rtb.DHRobot, q: np.ndarray) -> np.ndarray:
    return np.array([frame.A for frame in robot.fkine_all(q)])


@settings(max_examples=40, deadline=None)
@given(table, conventions, arrays(np.float64, (3, N_JOINTS), elements=st.floats(-7, 7)))
def test_every_frame_agrees_with_roboticstoolbox(params, convention, q) -> None:
    d, a, alpha_, offset = params
    chain = DHChain(d, a, alpha_, offset, convention=convention)
    robot = rtb_robot(d, a, alpha_, offset, convention)
    expected = np.stack([rtb_all_frames(robot, row) for row in q])
    one, ok_one = chain.link_poses(q[0])  # the single-configuration path
    batch, ok = chain.link_poses(q)  # the small-batch path
    assert one.shape == (N_JOINTS + 1, 4, 4) and batch.shape == (3, N_JOINTS + 1, 4, 4)
    assert ok_one.shape == () and bool(ok_one) and ok.all()
    np.testing.assert_allclose(one, expected[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(batch, expected, rtol=0, atol=1e-12)
    flange, _ = chain.forward(q)
    np.testing.assert_allclose(flange, expected[:, -1], rtol=0, atol=1e-12)


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_large_batches_agree_with_roboticstoolbox(convention: str) -> None:
    rng = np.random.default_rng(7)
    d, a = rng.uniform(-0.5, 0.5, (2, N_JOINTS))
    alpha_, offset = rng.uniform(-3, 3, (2, N_JOINTS))
    a[2] = d[4] = 0.0  # zero lengths take a shortcut in the column kernel
    alpha_[1], alpha_[3] = math.pi / 2, 0.0  # so do quarter and zero twists
    chain = DHChain(d, a, alpha_, offset, convention=convention)
    robot = rtb_robot(d, a, alpha_, offset, convention)
    q = rng.uniform(-4, 4, (5000, N_JOINTS))  # above the column kernel's threshold, odd blocks
    frames, ok = chain.link_poses(q.reshape(50, 100, N_JOINTS))
    assert frames.shape == (50, 100, N_JOINTS + 1, 4, 4) and ok.all()
    frames = frames.reshape(-1, N_JOINTS + 1, 4, 4)
    for row in rng.choice(len(q), 40, replace=False):
        np.testing.assert_allclose(frames[row], rtb_all_frames(robot, q[row]), atol=1e-12)
    flange_rtb = robot.ets().eval(q)
    np.testing.assert_allclose(frames[:, -1], flange_rtb, rtol=0, atol=1e-12)
    flange, _ = chain.forward(q)
    np.testing.assert_allclose(flange, flange_rtb, rtol=0, atol=1e-12)


def seed_transformation_matrix(theta, alpha_prev, a_prev, d) -> np.ndarray:
    """Seed 004's GetTransformationMatrix, one joint, entry by entry."""
    ct, st_, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha_prev), math.sin(alpha_prev)
    return np.array(
        [
            [ct, -st_, 0.0, a_prev],
            [ca * st_, ca * ct, -sa, -d * sa],
            [sa * st_, sa * ct, ca, d * ca],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


@settings(max_examples=30, deadline=None)
@given(table, arrays(np.float64, (N_JOINTS,), elements=st.floats(-4, 4)))
def test_modified_convention_is_the_seeds_matrix(params, q) -> None:
    d, a, alpha_, offset = params
    chain = DHChain(d, a, alpha_, offset, convention="modified")
    frames, _ = chain.link_poses(q)
    expected = np.eye(4)
    for i in range(N_JOINTS):
        expected = expected @ seed_transformation_matrix(q[i] + offset[i], alpha_[i], a[i], d[i])
        np.testing.assert_allclose(frames[i + 1], expected, rtol=0, atol=1e-12)


def test_first_frame_is_the_base_and_rotations_stay_orthonormal() -> None:
    chain = DHChain(**PUMA_LIKE)
    q = np.random.default_rng(1).uniform(-3, 3, (300, 6))
    frames, _ = chain.link_poses(q)
    np.testing.assert_array_equal(frames[:, 0], np.broadcast_to(np.eye(4), (300, 4, 4)))
    rot = frames[..., :3, :3]
    identity = np.broadcast_to(np.eye(3), rot.shape)
    np.testing.assert_allclose(rot @ np.swapaxes(rot, -1, -2), identity, atol=1e-12)
    bottom = np.broadcast_to([0.0, 0.0, 0.0, 1.0], frames.shape[:-2] + (4,))
    np.testing.assert_array_equal(frames[..., 3, :], bottom)


def test_params_rebuild_the_same_chain_through_json() -> None:
    chain = DHChain(**PUMA_LIKE, convention="modified")
    params = json.loads(json.dumps(chain.params()))
    assert params["convention"] == "modified" and len(params["limits"]) == 6
    twin = DHChain(**params)
    q = np.random.default_rng(2).uniform(-3, 3, (20, 6))
    np.testing.assert_array_equal(twin.link_poses(q)[0], chain.link_poses(q)[0])


def test_non_finite_joints_are_not_ok_and_do_not_raise() -> None:
    chain = DHChain(**PUMA_LIKE)
    q = np.zeros((300, 6))  # enough rows for the column kernel
    q[1, 2], q[2, 5] = np.nan, np.inf
    poses, ok = chain.link_poses(q)
    np.testing.assert_array_equal(ok[:4], [True, False, False, True])
    assert ok[3:].all() and np.isfinite(poses).all()
    flange, ok = chain.forward(q)
    assert not ok[1] and not ok[2] and np.isfinite(flange).all()
    for row in q[1:3]:
        pose, ok_one = chain.link_poses(row)
        assert not ok_one and np.isfinite(pose).all()
        assert not chain.forward(row[None])[1][0]


def test_wrong_joint_count_is_rejected() -> None:
    with pytest.raises(ValueError, match="shape"):
        DHChain(**PUMA_LIKE).link_poses(np.zeros(5))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1), conventions)
def test_inverse_of_forward_reproduces_the_pose(seed, convention) -> None:
    chain = DHChain(**PUMA_LIKE, convention=convention)
    lim = chain.joint_limits()
    rng = np.random.default_rng(seed)
    q_true, q_start = rng.uniform(lim[:, 0], lim[:, 1], (2, 6))
    target, _ = chain.forward(q_true)
    q, ok = chain.inverse(target, q_ref=q_start)
    assert ok and chain.within_limits(q)
    np.testing.assert_allclose(chain.forward(q)[0], target, atol=1e-9)


def test_batch_inverse_solves_random_reachable_targets() -> None:
    chain = DHChain(**PUMA_LIKE)
    lim = chain.joint_limits()
    rng = np.random.default_rng(3)
    q_true = rng.uniform(lim[:, 0], lim[:, 1], (4, 25, 6))
    targets, _ = chain.forward(q_true)
    q, ok = chain.inverse(targets, q_ref=rng.uniform(lim[:, 0], lim[:, 1], (4, 25, 6)))
    assert q.shape == (4, 25, 6) and ok.shape == (4, 25)
    assert ok.mean() >= 0.99
    assert chain.within_limits(q[ok]).all()
    np.testing.assert_allclose(chain.forward(q[ok])[0], targets[ok], atol=1e-9)


def test_inverse_prefers_the_reference_when_it_already_solves() -> None:
    chain = DHChain(**PUMA_LIKE)
    q_true = np.array([0.3, -0.4, 0.5, 1.0, -0.7, 0.2])
    q, ok = chain.inverse(chain.forward(q_true)[0], q_ref=q_true)
    assert ok
    np.testing.assert_allclose(q, q_true, atol=1e-12)


def test_inverse_is_deterministic() -> None:
    chain = DHChain(**PUMA_LIKE)
    target, _ = chain.forward(np.array([1.0, 0.2, -0.3, 0.4, 0.5, -0.6]))
    first, second = chain.inverse(target), chain.inverse(target)
    np.testing.assert_array_equal(first[0], second[0])


def test_unreachable_or_invalid_targets_fail_cleanly() -> None:
    chain = DHChain(**PUMA_LIKE)
    far = np.eye(4)
    far[:3, 3] = [5.0, 0.0, 0.0]  # 5 m away from an arm under 1.5 m long
    invalid = np.full((4, 4), np.nan)
    q, ok = chain.inverse(np.stack([far, invalid]))
    assert not ok.any()
    assert np.isfinite(q).all() and chain.within_limits(q).all()
