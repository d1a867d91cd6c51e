"""Type 12 five-bar (seed 000): reference posture, hand-worked postures, round trips, bad input."""

from __future__ import annotations

import cmath
import math

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from server.kinematics import Type12

KIN = Type12()  # the seed's lengths: L1..L5 = 200, 150, 100, 200, 100 mm
L1, L2, L3, L4, L5 = 0.2, 0.15, 0.1, 0.2, 0.1


def cos_theta(a0: float, a1: float) -> float:
    """The appendix's (3): the cosine of the angle at T between T->W and T->E."""
    t = L1 * cmath.exp(1j * (a0 + math.pi))
    w = L5 * cmath.exp(1j * (a1 + 1.5 * math.pi))
    dist = abs(w - t)
    return (dist**2 + L3**2 - L4**2) / (2 * dist * L3)


def seed_tcp(a0: float, a1: float) -> complex:
    """Seed 000's AxesToCartesian on complex numbers: T, W, then E right-handed, then TCP."""
    t = L1 * cmath.exp(1j * (a0 + math.pi))
    w = L5 * cmath.exp(1j * (a1 + 1.5 * math.pi))
    dist = abs(w - t)
    theta = math.acos(cos_theta(a0, a1))  # appendix (3)
    e = t + L3 * (w - t) / dist * cmath.exp(-1j * theta)  # (4), turned by -theta: (5)
    return t + (e - t) * L2 / L3


def tip(pose: np.ndarray) -> complex:
    return complex(pose[0, 3], pose[1, 3])


def test_reference_posture_is_the_seeds_parallelogram() -> None:
    pose, ok = KIN.forward(np.zeros(2))
    assert ok
    # T = (-L1, 0), W = (0, -L5), E = T + W; TCP on T->E stretched to L2.
    np.testing.assert_allclose(pose[:2, 3], [-0.2, -0.15], atol=1e-15)
    np.testing.assert_allclose(pose[:3, :3], np.eye(3), atol=0)
    assert pose[2, 3] == 0.0
    links, _ = KIN.link_poses(np.zeros(2))
    t, w = links[3, :2, 3], links[2, :2, 3]  # L2 pivots at T, L4 at W
    e = w + L4 * links[2, :2, 0]  # L4 points from W to E
    np.testing.assert_allclose(t, [-L1, 0.0], atol=1e-15)
    np.testing.assert_allclose(w, [0.0, -L5], atol=1e-15)
    np.testing.assert_allclose(e, t + w, atol=1e-15)


def test_a_posture_worked_by_hand() -> None:
    # a0 = -90 deg puts T at (0, 0.2); a1 = -90 deg puts W at (-0.1, 0). W - T = (-0.1, -0.2)
    # and |W - T|^2 = 0.05 = L3^2 + L4^2, so cos(theta) = 1 / sqrt(5), sin(theta) = 2 / sqrt(5).
    # Turning the unit vector (-1, -2) / sqrt(5) by -theta gives (-1, 0): E = (-0.1, 0.2),
    # and the TCP continues T -> E to L2: (-0.15, 0.2).
    pose, ok = KIN.forward(np.radians([-90.0, -90.0]))
    assert ok
    np.testing.assert_allclose(pose[:2, 3], [-0.15, 0.2], atol=1e-15)


@settings(max_examples=300)
@given(st.floats(-math.pi, math.pi), st.floats(-math.pi, math.pi))
def test_postures_agree_with_the_seed_worked_independently(a0, a1) -> None:
    # Every posture but the seam where L3 and L4 stretch out straight (a1 = a0 +/- 90 deg):
    # there E is defined only to the square root of the rounding error, by either formula.
    assume(1.0 - abs(cos_theta(a0, a1)) > 1e-6)
    pose, ok = KIN.forward(np.array([a0, a1]))
    assert ok
    assert abs(tip(pose) - seed_tcp(a0, a1)) < 1e-12


working_mode = st.tuples(st.floats(-1.0, 1.0), st.floats(-1.2, 1.2)).map(
    lambda v: np.array([v[0], v[0] + v[1]])  # a1 within 69 deg of a0, around the reference
)


@settings(max_examples=300)
@given(working_mode)
def test_inverse_of_forward_returns_the_joints(q) -> None:
    pose, ok = KIN.forward(q)
    assert ok
    back, ok_back = KIN.inverse(pose)
    assert ok_back
    np.testing.assert_allclose(back, q, atol=1e-9)


@settings(max_examples=300)
@given(st.floats(-math.pi, math.pi), st.floats(-math.pi, math.pi))
def test_forward_of_inverse_returns_the_tcp_anywhere(a0, a1) -> None:
    pose, ok = KIN.forward(np.array([a0, a1]))
    back, ok_back = KIN.inverse(pose)
    assert np.all(np.abs(back) <= math.pi)  # the seed's command range [-180, 180] deg
    if ok and ok_back:  # may be the other assembly mode, but the same TCP
        again, ok_again = KIN.forward(back)
        assert ok_again
        assert abs(tip(again) - tip(pose)) < 1e-12


def test_batches_keep_leading_axes_and_match_single_calls() -> None:
    q = np.random.default_rng(0).uniform(-0.8, 0.8, (7, 3000, 2))  # several forward blocks
    pose, ok = KIN.forward(q)
    assert pose.shape == (7, 3000, 4, 4) and ok.shape == (7, 3000) and ok.all()
    for i, j in [(0, 0), (3, 1234), (6, 2999)]:
        np.testing.assert_array_equal(pose[i, j], KIN.forward(q[i, j])[0])
    links, ok_links = KIN.link_poses(q)
    assert links.shape == (7, 3000, 4, 4, 4) and ok_links.all()


def test_unreachable_and_invalid_input_is_not_ok_but_finite() -> None:
    far = np.eye(4)
    far[:2, 3] = [3.0, 3.0]
    inside = np.eye(4)  # the TCP at the base joint: closer than |L1 - L2| allows
    poses = np.stack([far, inside, np.full((4, 4), np.nan)])
    q, ok = KIN.inverse(poses)
    assert not ok.any() and np.isfinite(q).all()
    joints = np.array([[np.nan, 0.0], [0.0, np.inf], [0.1, 0.2]])
    pose, ok = KIN.forward(joints)
    np.testing.assert_array_equal(ok, [False, False, True])
    assert np.isfinite(pose).all()
    links, ok = KIN.link_poses(joints)
    np.testing.assert_array_equal(ok, [False, False, True])
    assert np.isfinite(links).all()


def test_joints_that_tear_the_mechanism_apart_are_not_ok() -> None:
    # With the seed's lengths every posture closes; with L1 = 0.3 and L4 = 0.25, L1 and L5
    # pointing apart leave |W - T| = 0.4, more than L3 + L4 = 0.35.
    kin = Type12(l1=0.3, l2=0.2, l3=0.1, l4=0.25, l5=0.1)
    pose, ok = kin.forward(np.array([[0.0, 0.0], [0.0, math.pi / 2]]))
    np.testing.assert_array_equal(ok, [True, False])
    assert np.isfinite(pose).all()
