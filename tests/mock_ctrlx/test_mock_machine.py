"""The simulated machine: smooth, within limits, reachable, and commandable."""

from __future__ import annotations

import numpy as np
import pytest

from server.kinematics import Type12
from server.mock_ctrlx import Machine, demo_groups

LIMITS_DEG = {f"iiwa_a{i + 1}": lim for i, lim in enumerate((170, 120, 170, 120, 170, 120, 175))}


def trace(machine: Machine, group: str, dt: float = 0.01) -> np.ndarray:
    """Positions of ``group`` over one whole cycle (plus a bit), every ``dt`` seconds."""
    period = machine._cycles[group].period_s
    return np.array([machine.group_positions(group, t) for t in np.arange(0, period + 1, dt)])


@pytest.mark.parametrize("group", ["kin12", "iiwa", "pos"])
def test_cycles_are_continuous_and_respect_velocity_limits(group: str) -> None:
    machine, dt = Machine(), 0.01
    q = trace(machine, group, dt)
    v_max = np.array([a.v_max for a in machine.groups[group].axes])
    assert np.all(np.abs(np.diff(q, axis=0)) <= v_max * dt * (1 + 1e-9))
    assert np.ptp(q, axis=0).min() > 10.0, "every axis moves"


def test_demo_targets_keep_clear_of_limits_and_type12_closes_everywhere() -> None:
    machine = Machine()
    kin12 = trace(machine, "kin12")
    assert np.abs(kin12).max() <= 40.0
    _, ok = Type12().forward(np.radians(kin12))
    assert ok.all()
    iiwa = trace(machine, "iiwa")
    limits = np.array(list(LIMITS_DEG.values()))
    assert np.all(np.abs(iiwa) <= 0.7 * limits + 1e-9)
    assert np.abs(trace(machine, "pos")[:, 0]).max() <= 60.0


def test_positions_are_a_pure_function_of_time() -> None:
    a, b = Machine(), Machine()
    for t in (0.0, 1.7e9, 1.7e9 + 3.21):
        assert a.snapshot(t) == b.snapshot(t)
    assert set(a.snapshot(0.0)) == {ax.name for g in demo_groups() for ax in g.axes}


def test_commands_move_there_and_hold() -> None:
    machine = Machine()
    duration = machine.command("kin12", [10.0, -5.0], t=100.0)
    assert duration > 0.0
    assert machine.group_positions("kin12", 100.0 + duration + 1.0) == pytest.approx([10.0, -5.0])
    held = machine.command_axis("iiwa_a4", -30.0, t=200.0) + 1.0  # the demo resumes later
    before = machine.group_positions("iiwa", 200.0)
    after = machine.group_positions("iiwa", 200.0 + held)
    assert after[3] == pytest.approx(-30.0)
    assert np.delete(after, 3) == pytest.approx(np.delete(before, 3))
    with pytest.raises(ValueError, match="outside"):
        machine.command("kin12", [50.0, 0.0])
    machine.resume_demo("kin12")
    assert machine.group_positions("kin12", 1.0) == pytest.approx(
        Machine().group_positions("kin12", 1.0)
    )
