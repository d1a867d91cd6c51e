"""CosSin, the batch kernels' cos and sin: within two ulps of libm, and libm itself out of range."""

from __future__ import annotations

import math

import numpy as np
import pytest

from server.kinematics._trig import STEP, CosSin


@pytest.mark.parametrize("scale", [1e-9, 1e-3, 0.5, math.pi, 7.0, 25.0])
def test_within_two_ulps_of_libm(scale: float) -> None:
    rng = np.random.default_rng(1)
    theta = rng.uniform(-scale, scale, (7, 20_000))
    # Table angles, halfway between them, and the usual suspects.
    special = np.array([0.0, -0.0, STEP, 1.5 * STEP, -2.5 * STEP, math.pi / 2, -math.pi, 1e-300])
    theta[0, : special.size] = np.where(np.abs(special) <= scale, special, 0.0)
    cos, sin = np.empty_like(theta), np.empty_like(theta)
    CosSin(theta.shape)(theta, cos, sin)
    assert np.abs(cos - np.cos(theta)).max() <= 2.3e-16
    assert np.abs(sin - np.sin(theta)).max() <= 2.3e-16
    small = np.abs(theta) < 1e-3  # near zero, sin is as close relatively
    assert np.all(np.abs(sin - np.sin(theta))[small] <= 2 * np.spacing(np.abs(theta[small])))


def test_beyond_the_table_and_not_finite_fall_back_to_libm() -> None:
    theta = np.array([[0.3, 30.0, -1e6], [np.nan, np.inf, 2.0]])
    cos, sin = np.empty_like(theta), np.empty_like(theta)
    with np.errstate(invalid="ignore"):
        CosSin(theta.shape)(theta, cos, sin)
        np.testing.assert_array_equal(cos, np.cos(theta))
        np.testing.assert_array_equal(sin, np.sin(theta))
