"""cells/demo.toml is the demo cell that used to be Python: same robots, nodes, bases and poses."""

from __future__ import annotations

import numpy as np

from server.kinematics import Type12, WorldModel, iiwa7
from tests.conftest import demo_cell


def axis_node(axis: str) -> str:
    return f"motion/axs/{axis}/state/values/actual/pos"


def positioner_world() -> WorldModel:
    """The positioner as server/cell/default.py built it, call for call."""
    world = WorldModel()
    world.axis_group_add("positioner", [0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    world.axis_group_add_axis(
        "positioner", "pos_tilt", "", [0.0, 0.0, 0.45, 0.0, np.pi / 2, 0.0], 0, 1.0, 1.0,
        q_limits=[-np.pi / 3, np.pi / 3],
    )  # fmt: skip
    world.axis_group_add_axis(
        "positioner", "pos_turn", "pos_tilt", [-0.1, 0.0, 0.0, 0.0, -np.pi / 2, 0.0], 0, 1.0, 1.0,
        q_limits=[-2 * np.pi, 2 * np.pi],
    )  # fmt: skip
    return world


def test_same_robots_nodes_links_and_bases() -> None:
    cell = demo_cell()
    assert [r.name for r in cell.robots] == ["kin12", "iiwa7", "positioner"]
    kin12, iiwa, positioner = cell.robots
    assert kin12.nodes == (axis_node("kin12_a0"), axis_node("kin12_a1"))
    assert iiwa.nodes == tuple(axis_node(f"iiwa_a{i}") for i in range(1, 8))
    assert positioner.nodes == (axis_node("pos_tilt"), axis_node("pos_turn"))
    assert all(j.source_unit == "deg" for r in cell.robots for j in r.joints)
    assert kin12.link_names == ("L1", "L5", "L4", "L2")
    assert iiwa.link_names == tuple(f"link{i}" for i in range(8))
    assert positioner.link_names == ("base", "tilt", "table")
    np.testing.assert_allclose(kin12.base, [-0.75, 0.35, 0, 0, 0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(iiwa.base, [0, 0, 0, 0, 0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(positioner.base, [1.35, 0, 0, 0, 0, 0, 1], atol=1e-15)
    assert all(m is not None and m.is_file() for r in cell.robots for m in r.meshes)


def test_same_poses_for_the_same_joints() -> None:
    rng = np.random.default_rng(12)
    kin12, iiwa, positioner = demo_cell().robots
    old = {
        "kin12": Type12().link_poses,
        "iiwa7": iiwa7().link_poses,
        "positioner": lambda q: positioner_world().link_poses("positioner", q),
    }
    for robot, deg in (
        (kin12, rng.uniform(-40, 40, (50, 2))),
        (iiwa, rng.uniform(-110, 110, (50, 7))),
        (positioner, rng.uniform([-60, -300], [60, 300], (50, 2))),
    ):
        q = robot.to_si(deg)
        np.testing.assert_allclose(q, np.radians(deg), rtol=1e-15)
        links, _, ok = robot.poses(q)
        expected, expected_ok = old[robot.name](q)
        np.testing.assert_array_equal(ok, expected_ok)
        np.testing.assert_allclose(links, expected, atol=1e-12, err_msg=robot.name)


def test_the_iiwa_keeps_its_analytic_inverse_and_limits() -> None:
    iiwa = demo_cell().robots[1]
    reference = iiwa7()
    assert type(iiwa.kinematics) is type(reference)
    np.testing.assert_allclose(iiwa.limits, reference.joint_limits(), rtol=1e-15)
