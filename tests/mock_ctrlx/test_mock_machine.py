"""The simulated machine: smooth, within limits, reachable, and commandable."""

from __future__ import annotations

import numpy as np
import pytest

from server.kinematics import Type12
from server.mock_ctrlx import HOLD_S, Machine, demo_groups

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


@pytest.mark.parametrize("hold_s", [0.5, 2.0])
def test_a_commanded_move_returns_to_the_demo_cycle_smoothly(hold_s: float) -> None:
    machine, fresh, t0 = Machine(hold_s=hold_s), Machine(), 1000.0
    group = machine.groups["iiwa"]
    duration = machine.command("iiwa", [10.0, -20.0, 30.0, -40.0, 50.0, 60.0, -70.0], t=t0)
    arrived = t0 + duration
    assert machine.group_positions("iiwa", arrived + 0.9 * hold_s) == pytest.approx(
        [10.0, -20.0, 30.0, -40.0, 50.0, 60.0, -70.0]
    )
    # Back on the cycle for good: from some time on it is the demo cycle, shifted in time.
    commanded = machine._commanded["iiwa"]
    resume = commanded.resume_t
    assert resume > arrived + hold_s
    for dt in (0.0, 0.77, 3.1, 11.0, 40.0):
        assert machine.group_positions("iiwa", resume + dt) == pytest.approx(
            fresh.group_positions("iiwa", dt)
        )
    # Continuous and within the velocity limits all the way (no jump back to the cycle).
    step = 0.005
    q = np.array([machine.group_positions("iiwa", t) for t in np.arange(t0, resume + 5, step)])
    v_max = np.array([a.v_max for a in group.axes])
    assert np.all(np.abs(np.diff(q, axis=0)) <= v_max * step * (1 + 1e-9))


def test_a_commanded_pose_is_held_30_s_by_default_or_until_the_next_command() -> None:
    machine, target = Machine(), [10.0, -20.0, 30.0, -40.0, 50.0, 60.0, -70.0]
    arrived = machine.command("iiwa", target, t=0.0)
    assert machine.hold_s == HOLD_S == 30.0
    assert machine.group_positions("iiwa", arrived + 29.9) == pytest.approx(target)
    assert machine.group_positions("iiwa", arrived + 30.5) != pytest.approx(target)
    second = [0.0, 20.0, -30.0, 40.0, -50.0, 0.0, 70.0]
    took = machine.command("iiwa", second, t=arrived + 10.0)  # the next command ends the hold
    assert machine.group_positions("iiwa", arrived + 10.0 + took) == pytest.approx(second)
    with pytest.raises(ValueError, match="hold_s"):
        Machine(hold_s=-1.0)


def test_a_new_command_during_the_return_starts_from_where_the_group_is() -> None:
    machine = Machine(hold_s=0.1)
    duration = machine.command("kin12", [20.0, 20.0], t=0.0)
    t = duration + 0.1 + 0.2  # on the way back to the first demo target
    here = machine.group_positions("kin12", t)
    assert not np.allclose(here, [20.0, 20.0]) and not np.allclose(here, [0.0, 0.0])
    machine.command("kin12", [-10.0, 5.0], t=t)
    assert machine.group_positions("kin12", t) == pytest.approx(here)


def test_axes_in_any_unit_and_at_any_node_are_served() -> None:
    from server.mock_ctrlx import UNITS, AxisGroup, NodeTree, SimAxis, Snapshot

    axes = (
        SimAxis("j1", "rad", 1.0, 4.0, -3.0, 3.0, node="plc/app/Application/sym/PLC_PRG/rJ1"),
        SimAxis("j2", "m", 0.5, 2.0, 0.0, 1.0, node="/robots/r1/lift/"),
        SimAxis("j3", "deg", 90.0, 300.0),
    )
    machine = Machine(groups=[AxisGroup("r1", axes, ((0.0, 0.0, 0.0), (1.0, 0.5, 45.0)))])
    tree = NodeTree(machine)
    assert [a.position_node for a in axes] == [
        "plc/app/Application/sym/PLC_PRG/rJ1",
        "robots/r1/lift",
        "motion/axs/j3/state/values/actual/pos",
    ]
    positions = machine.snapshot(2.0)
    for axis in axes:
        assert tree.read(axis.position_node, Snapshot(machine, 2.0)) == {
            "type": "double",
            "value": positions[axis.name],
        }
        assert tree.metadata(axis.position_node)["unit"] == axis.unit
    assert tree.browse("robots/r1") == ["lift"]
    assert "rJ1" in tree.browse("plc/app/Application/sym/PLC_PRG")
    assert tree.browse("motion/axs") == ["j3"]  # axes at their own node have no motion/axs
    assert set(UNITS) == {"deg", "rad", "mm", "m"}
    with pytest.raises(ValueError, match="unit"):
        SimAxis("bad", "inch", 1.0, 1.0)  # type: ignore[arg-type]
    twice = (SimAxis("a", "deg", 1, 1, node="x/y"), SimAxis("b", "deg", 1, 1, node="x/y"))
    with pytest.raises(ValueError, match="served twice: x/y"):
        NodeTree(Machine(groups=[AxisGroup("g", twice, ((0.0, 0.0),))]))
