"""Axis-group world model (seed 003): worked examples, rules, FK and simulated motion."""

from __future__ import annotations

import json
import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from server.kinematics import WorldModel

POSE = [0.1, -0.2, 0.3, 0.2, -0.4, 0.6]


def _seed_index_example() -> WorldModel:
    """axis_group_get_actual_positions example: Axis1 at 2, then 0, 1, 3 assigned."""
    wm = WorldModel()
    wm.axis_group_add("AxisGroup1", POSE)
    wm.axis_group_add_axis("AxisGroup1", "Axis1", "", POSE, 0, 1, 1, [-1, 1], axis_index=2)
    wm.axis_group_add_axis("AxisGroup1", "Axis2", "", POSE, 0, 1, 1, [-1, 1])
    wm.axis_group_add_axis("AxisGroup1", "Axis3", "", POSE, 0, 1, 1, [-1, 1])
    wm.axis_group_add_axis("AxisGroup1", "Axis4", "", POSE, 0, 1, 1, [-1, 1])
    return wm


def _two_axis_example() -> WorldModel:
    """movej / speedj examples: Axis1 at index 3, Axis2 at index 1."""
    wm = WorldModel()
    wm.axis_group_add("AxisGroup1", POSE)
    wm.axis_group_add_axis("AxisGroup1", "Axis1", "", POSE, 0, 1, 1, [-3, 3], 3)
    wm.axis_group_add_axis("AxisGroup1", "Axis2", "", POSE, 0, 1, 1, [-3, 3], 1)
    return wm


def _run(wm: WorldModel, seconds: float, dt: float = 0.01) -> None:
    for _ in range(int(round(seconds / dt))):
        wm.advance(dt)


# -- the seed's worked examples ------------------------------------------------------------


def test_arrays_are_ordered_by_axis_index() -> None:
    wm = _seed_index_example()
    order = [wm.axis_group_get_axis_name(i) for i in range(4)]
    assert order == ["Axis2", "Axis3", "Axis1", "Axis4"]
    assert [wm.axis_group_get_axis_index(n) for n in ("Axis1", "Axis2", "Axis3", "Axis4")] == [
        2,
        0,
        1,
        3,
    ]
    wm.axis_group_movej("AxisGroup1", [0.1, 0.2, 0.3, 0.4], 1, 1)
    _run(wm, 2.0)
    actual = wm.axis_group_get_actual_positions("AxisGroup1")
    np.testing.assert_allclose(actual, [0.1, 0.2, 0.3, 0.4])
    # Axis2 is first, Axis1 third: the name order would put them the other way.
    params = wm.params("AxisGroup1")
    assert [ax["name"] for ax in params["axes"]] == ["Axis2", "Axis3", "Axis1", "Axis4"]


def test_get_axis_index_and_name_example() -> None:
    wm = WorldModel()
    wm.axis_group_add("AxisGroup1", POSE)
    wm.axis_group_add_axis("AxisGroup1", "Axis1", "", POSE, 0, 1, 1, q_limits=[-1, 1], axis_index=3)
    assert wm.axis_group_get_axis_index("Axis1") == 3
    assert wm.axis_group_get_axis_name(3) == "Axis1"
    # The next axis takes the lowest free index.
    wm.axis_group_add_axis("AxisGroup1", "Axis2", "Axis1", POSE, 0, 1, 1, q_limits=[-1, 1])
    assert wm.axis_group_get_axis_index("Axis2") == 0


def test_update_axis_example_widens_the_limits() -> None:
    wm = WorldModel()
    wm.axis_group_add("AxisGroup1", POSE)
    wm.axis_group_add_axis("AxisGroup1", "Axis1", "", POSE, 0, 1, 1, q_limits=[-1, 1])
    wm.axis_group_movej("AxisGroup1", [1.5], 1, 1)
    np.testing.assert_array_equal(wm.axis_group_get_target_positions("AxisGroup1"), [1.0])
    _run(wm, 5.0)
    wm.axis_group_update_axis("Axis1", q_limits=[-1, 2])
    assert wm.params("AxisGroup1")["axes"][0]["q_limits"] == [-1.0, 2.0]
    wm.axis_group_movej("AxisGroup1", [1.5], 1, 1)
    np.testing.assert_array_equal(wm.axis_group_get_target_positions("AxisGroup1"), [1.5])
    _run(wm, 5.0)
    np.testing.assert_array_equal(wm.axis_group_get_actual_positions("AxisGroup1"), [1.5])
    wm.axis_group_update_axis("Axis1", q_limits=[])
    assert wm.params("AxisGroup1")["axes"][0]["q_limits"] == [-1e300, 1e300]


def test_movej_example_targets_in_index_order() -> None:
    wm = _two_axis_example()
    wm.axis_group_movej("AxisGroup1", [2, -1], 1, 1)
    # "Axis2" (index 1) comes before "Axis1" (index 3). (The seed's comment says Axis2
    # goes to 0 rad; with [2, -1] and limits [-3, 3] the array gives it 2.)
    np.testing.assert_array_equal(wm.axis_group_get_target_positions("AxisGroup1"), [2, -1])
    assert wm.is_moving("AxisGroup1")
    _run(wm, 5.0)
    assert not wm.is_moving("AxisGroup1")
    np.testing.assert_array_equal(wm.axis_group_get_actual_positions("AxisGroup1"), [2, -1])
    assert wm.frame_pose("Axis1") @ np.array([1.0, 0, 0, 1]) == pytest.approx(
        _naive_frame(wm.params("AxisGroup1"), {"Axis1": -1.0, "Axis2": 2.0}, "Axis1") @ [1, 0, 0, 1]
    )


def test_speedj_example_velocities_in_index_order() -> None:
    wm = _two_axis_example()
    wm.axis_group_speedj("AxisGroup1", [-0.5, 0.5], 1)
    _run(wm, 0.5)
    before = wm.axis_group_get_actual_positions("AxisGroup1")
    _run(wm, 1.0)
    after = wm.axis_group_get_actual_positions("AxisGroup1")
    # Past the 0.5 s ramp, Axis2 runs at -0.5 rad/s and Axis1 at +0.5 rad/s.
    np.testing.assert_allclose(after - before, [-0.5, 0.5], atol=1e-9)
    assert wm.axis_group_get_axis_name(1) == "Axis2"
    np.testing.assert_array_equal(wm.axis_group_get_target_positions("AxisGroup1"), after)
    # speedj to zero stops the group.
    wm.axis_group_speedj("AxisGroup1", [0, 0], 1)
    _run(wm, 1.0)
    assert not wm.is_moving("AxisGroup1")
    stopped = wm.axis_group_get_actual_positions("AxisGroup1")
    _run(wm, 1.0)
    np.testing.assert_array_equal(wm.axis_group_get_actual_positions("AxisGroup1"), stopped)


def test_speedj_is_clipped_to_the_velocity_limit_and_stops_after_t() -> None:
    wm = _two_axis_example()
    wm.axis_group_speedj("AxisGroup1", [5.0, -5.0], 1, t=2.0)
    _run(wm, 1.5)
    a = wm.axis_group_get_actual_positions("AxisGroup1")
    _run(wm, 0.25)
    b = wm.axis_group_get_actual_positions("AxisGroup1")
    np.testing.assert_allclose((b - a) / 0.25, [1.0, -1.0], atol=1e-9)
    _run(wm, 2.0)
    assert not wm.is_moving("AxisGroup1")


def _at(wm: WorldModel, value: float) -> None:
    wm.axis_group_movej("AxisGroup1", [value], 1, 1)
    _run(wm, 10.0, dt=0.05)
    assert not wm.is_moving("AxisGroup1")


@pytest.mark.parametrize(
    ("offset_of", "expected"),
    [
        (lambda q: -q, 0.0),
        (lambda q: -math.ceil(q / math.tau) * math.tau, -7 * math.pi / 4),
        (lambda q: -math.floor(q / math.tau) * math.tau, math.pi / 4),
    ],
)
def test_offset_examples(offset_of: Callable[[float], float], expected: float) -> None:
    # The seed's two_pi = 2 * 3.1415 would land 4e-4 rad off; 2 * pi is the intent.
    wm = WorldModel()
    wm.axis_group_add("AxisGroup1", POSE)
    wm.axis_group_add_axis("AxisGroup1", "Axis1", "", POSE, 0, 1, 1)
    _at(wm, 9 * math.pi / 4)
    targets = wm.axis_group_get_target_positions("AxisGroup1")
    np.testing.assert_allclose(targets, [9 * math.pi / 4])
    np.testing.assert_allclose(wm.axis_group_get_actual_positions("AxisGroup1"), targets)
    wm.axis_group_offset_positions("AxisGroup1", [offset_of(float(targets[0]))])
    np.testing.assert_allclose(
        wm.axis_group_get_target_positions("AxisGroup1"), [expected], atol=1e-12
    )
    np.testing.assert_allclose(
        wm.axis_group_get_actual_positions("AxisGroup1"), [expected], atol=1e-12
    )


def test_offset_during_a_move_shifts_the_whole_profile() -> None:
    wm = _two_axis_example()
    wm.axis_group_movej("AxisGroup1", [1.0, 1.0], 1, 1)
    _run(wm, 0.5)
    before = wm.axis_group_get_actual_positions("AxisGroup1")
    wm.axis_group_offset_positions("AxisGroup1", [-1.0, 2.0])
    np.testing.assert_allclose(wm.axis_group_get_actual_positions("AxisGroup1"), before + [-1, 2])
    _run(wm, 5.0)
    np.testing.assert_allclose(wm.axis_group_get_actual_positions("AxisGroup1"), [0.0, 3.0])


def test_group_placed_in_another_frame() -> None:
    # The servoj example's setup: a group 1 m along -Y, an axis turned 90 deg about X.
    wm = WorldModel()
    wm.axis_group_add("groupA", [0, -1, 0, 0, 0, 0])
    wm.axis_group_add_axis("groupA", "axis1", "", [0, 0, 0, math.radians(90), 0, 0], 0, 10, 10)
    np.testing.assert_allclose(wm.frame_pose("axis1")[:3, 2], [0, -1, 0], atol=1e-12)
    np.testing.assert_allclose(wm.frame_pose("axis1")[:3, 3], [0, -1, 0], atol=1e-12)
    # A second group placed relative to the axis frame lands in world coordinates.
    wm.axis_group_add("groupB", [0, 0, 0.5, 0, 0, 0], ref_frame="axis1")
    np.testing.assert_allclose(wm.frame_pose("groupB")[:3, 3], [0, -1.5, 0], atol=1e-12)
    np.testing.assert_allclose(wm.frame_pose("base"), np.eye(4))


def test_delete_removes_the_group_and_frees_names_and_indices() -> None:
    wm = _seed_index_example()
    wm.axis_group_delete("AxisGroup1")
    with pytest.raises(ValueError, match="does not exist"):
        wm.axis_group_get_axis_index("Axis1")
    np.testing.assert_array_equal(wm.axis_group_get_actual_positions(), [])
    wm.axis_group_add("AxisGroup1", POSE)
    wm.axis_group_add_axis("AxisGroup1", "Axis1", "", POSE, 1, 1, 1)
    assert wm.axis_group_get_axis_index("Axis1") == 0


def test_all_positions_across_groups_by_index() -> None:
    wm = WorldModel()
    wm.axis_group_add("A", POSE)
    wm.axis_group_add("B", POSE)
    wm.axis_group_add_axis("B", "b0", "", POSE, 0, 1, 1, axis_index=0)
    wm.axis_group_add_axis("A", "a1", "", POSE, 1, 1, 1)
    wm.axis_group_offset_positions("A", [0.5])
    wm.axis_group_offset_positions("B", [-0.5])
    np.testing.assert_array_equal(wm.axis_group_get_actual_positions(), [-0.5, 0.5])
    np.testing.assert_array_equal(wm.axis_group_get_target_positions(""), [-0.5, 0.5])


# -- every rule raises ValueError naming it ------------------------------------------------


def _busy() -> WorldModel:
    wm = _two_axis_example()
    wm.axis_group_movej("AxisGroup1", [1.0, 1.0], 1, 1)
    return wm


RULES: list[tuple[str, Callable[[WorldModel], object], str]] = [
    ("empty group name", lambda w: w.axis_group_add("", POSE), "empty"),
    ("duplicate group", lambda w: w.axis_group_add("AxisGroup1", POSE), "unique"),
    ("group named like an axis", lambda w: w.axis_group_add("Axis1", POSE), "unique"),
    ("group named base", lambda w: w.axis_group_add("base", POSE), "unique"),
    ("bad pose size", lambda w: w.axis_group_add("G", [0, 0, 0]), "pose"),
    ("unknown ref frame", lambda w: w.axis_group_add("G", POSE, "nowhere"), "does not exist"),
    ("delete unknown", lambda w: w.axis_group_delete("nope"), "does not exist"),
    (
        "axis to unknown group",
        lambda w: w.axis_group_add_axis("nope", "A", "", POSE, 0, 1, 1),
        "does not exist",
    ),
    (
        "empty axis name",
        lambda w: w.axis_group_add_axis("AxisGroup1", "", "", POSE, 0, 1, 1),
        "empty",
    ),
    (
        "duplicate axis",
        lambda w: w.axis_group_add_axis("AxisGroup1", "Axis1", "", POSE, 0, 1, 1),
        "unique",
    ),
    (
        "axis named like group",
        lambda w: w.axis_group_add_axis("AxisGroup1", "AxisGroup1", "", POSE, 0, 1, 1),
        "unique",
    ),
    (
        "self parent",
        lambda w: w.axis_group_add_axis("AxisGroup1", "X", "X", POSE, 0, 1, 1),
        "closed chain",
    ),
    (
        "unknown parent",
        lambda w: w.axis_group_add_axis("AxisGroup1", "X", "Y", POSE, 0, 1, 1),
        "must exist in axis group",
    ),
    (
        "type 2",
        lambda w: w.axis_group_add_axis("AxisGroup1", "X", "", POSE, 2, 1, 1),
        "type can only be 0",
    ),
    (
        "v_limit 0",
        lambda w: w.axis_group_add_axis("AxisGroup1", "X", "", POSE, 0, 0, 1),
        "v_limit must be positive",
    ),
    (
        "a_limit < 0",
        lambda w: w.axis_group_add_axis("AxisGroup1", "X", "", POSE, 0, 1, -1),
        "a_limit must be positive",
    ),
    (
        "q_limits size",
        lambda w: w.axis_group_add_axis("AxisGroup1", "X", "", POSE, 0, 1, 1, [1]),
        "size of q_limits must be 2",
    ),
    (
        "q_limits empty on add",
        lambda w: w.axis_group_add_axis("AxisGroup1", "X", "", POSE, 0, 1, 1, []),
        "size of q_limits must be 2",
    ),
    (
        "q_limits order",
        lambda w: w.axis_group_add_axis("AxisGroup1", "X", "", POSE, 0, 1, 1, [1, 1]),
        "lower limit must be less than the upper",
    ),
    (
        "index 6",
        lambda w: w.axis_group_add_axis("AxisGroup1", "X", "", POSE, 0, 1, 1, None, 6),
        r"range of \[0, 5\]",
    ),
    (
        "index -1",
        lambda w: w.axis_group_add_axis("AxisGroup1", "X", "", POSE, 0, 1, 1, None, -1),
        r"range of \[0, 5\]",
    ),
    (
        "index taken",
        lambda w: w.axis_group_add_axis("AxisGroup1", "X", "", POSE, 0, 1, 1, None, 3),
        "already occupied",
    ),
    ("update unknown", lambda w: w.axis_group_update_axis("nope", v_limit=1), "does not exist"),
    (
        "update q_limits size",
        lambda w: w.axis_group_update_axis("Axis1", q_limits=[1, 2, 3]),
        "size of q_limits must be 0 or 2",
    ),
    (
        "update q_limits order",
        lambda w: w.axis_group_update_axis("Axis1", q_limits=[2, 1]),
        "lower limit",
    ),
    (
        "update index taken",
        lambda w: w.axis_group_update_axis("Axis1", axis_index=1),
        "already occupied",
    ),
    (
        "update index range",
        lambda w: w.axis_group_update_axis("Axis1", axis_index=7),
        r"range of \[0, 5\]",
    ),
    ("update type", lambda w: w.axis_group_update_axis("Axis1", type=3), "type can only be"),
    ("index of unknown axis", lambda w: w.axis_group_get_axis_index("nope"), "does not exist"),
    ("name of free index", lambda w: w.axis_group_get_axis_name(0), "no axis has axis_index"),
    (
        "positions of unknown group",
        lambda w: w.axis_group_get_actual_positions("nope"),
        "does not exist",
    ),
    (
        "targets of unknown group",
        lambda w: w.axis_group_get_target_positions("nope"),
        "does not exist",
    ),
    (
        "offset size",
        lambda w: w.axis_group_offset_positions("AxisGroup1", [1.0]),
        "must match the number of axes",
    ),
    (
        "movej size",
        lambda w: w.axis_group_movej("AxisGroup1", [1.0, 2.0, 3.0], 1, 1),
        "must match the number of axes",
    ),
    (
        "movej a = 0",
        lambda w: w.axis_group_movej("AxisGroup1", [1.0, 2.0], 0, 1),
        r"a must be in range of \(0, 1\]",
    ),
    (
        "movej v > 1",
        lambda w: w.axis_group_movej("AxisGroup1", [1.0, 2.0], 1, 1.5),
        r"v must be in range of \(0, 1\]",
    ),
    ("movej unknown group", lambda w: w.axis_group_movej("nope", [1.0], 1, 1), "does not exist"),
    ("speedj size", lambda w: w.axis_group_speedj("AxisGroup1", [1.0], 1), "must match"),
    (
        "speedj a > 1",
        lambda w: w.axis_group_speedj("AxisGroup1", [1.0, 1.0], 2),
        r"a must be in range of \(0, 1\]",
    ),
    ("link_poses size", lambda w: w.link_poses("AxisGroup1", [0.0]), r"shape \(\.\.\., 2\)"),
    ("frame of unknown", lambda w: w.frame_pose("nope"), "does not exist"),
    ("advance backwards", lambda w: w.advance(-1.0), "non-negative"),
]


@pytest.mark.parametrize(("rule", "call", "message"), RULES, ids=[r[0] for r in RULES])
def test_rule_violations_raise_and_change_nothing(rule: str, call, message: str) -> None:
    wm = _two_axis_example()
    before = (json.dumps(wm.params("AxisGroup1")), wm.axis_group_get_target_positions().tolist())
    with pytest.raises(ValueError, match=message):
        call(wm)
    after = (json.dumps(wm.params("AxisGroup1")), wm.axis_group_get_target_positions().tolist())
    assert after == before


def test_at_most_six_groups() -> None:
    wm = WorldModel()
    for i in range(6):
        wm.axis_group_add(f"G{i}", POSE)
    with pytest.raises(ValueError, match="at most 6 axis groups"):
        wm.axis_group_add("G6", POSE)


def test_at_most_six_axes() -> None:
    wm = WorldModel()
    wm.axis_group_add("G", POSE)
    for i in range(6):
        wm.axis_group_add_axis("G", f"A{i}", "", POSE, 0, 1, 1)
    with pytest.raises(ValueError, match="every axis index"):
        wm.axis_group_add_axis("G", "A6", "", POSE, 0, 1, 1)


@pytest.mark.parametrize(
    "call",
    [
        lambda w: w.axis_group_add_axis("AxisGroup1", "X", "", POSE, 0, 1, 1),
        lambda w: w.axis_group_update_axis("Axis1", v_limit=2.0),
        lambda w: w.axis_group_delete("AxisGroup1"),
    ],
)
def test_group_under_control_refuses_changes(call) -> None:
    wm = _busy()
    with pytest.raises(ValueError, match="under control"):
        call(wm)
    _run(wm, 5.0)
    call(wm)


# -- forward kinematics --------------------------------------------------------------------


def _naive_matrix(pose: list[float]) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = Rotation.from_rotvec(pose[3:]).as_matrix()
    out[:3, 3] = pose[:3]
    return out


def _naive_frame(params: dict, q: dict[str, float], name: str) -> np.ndarray:
    """World pose of axis ``name`` from ``params`` alone, one frame at a time."""
    axes = {ax["name"]: ax for ax in params["axes"]}
    ax = axes[name]
    parent = (
        _naive_matrix(params["pose"])
        if ax["parent"] == ""
        else _naive_frame(params, q, ax["parent"])
    )
    joint = np.eye(4)
    if ax["type"] == 0:
        joint[:3, :3] = Rotation.from_euler("z", q[name]).as_matrix()
    else:
        joint[2, 3] = q[name]
    return parent @ _naive_matrix(ax["pose"]) @ joint


def _tree_world(rng: np.random.Generator) -> WorldModel:
    """Six axes, mixed types, a tree three deep, indices scrambled against insertion order."""
    wm = WorldModel()
    wm.axis_group_add("G", rng.normal(size=6))
    spec = [
        ("a", "", 0, 4),
        ("b", "a", 1, 0),
        ("c", "", 1, 5),
        ("d", "b", 0, 2),
        ("e", "a", 0, 1),
        ("f", "G", 0, 3),
    ]
    for name, parent, kind, index in spec:
        wm.axis_group_add_axis("G", name, parent, rng.normal(size=6), kind, 1, 1, [-2, 2], index)
    return wm


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_link_poses_agree_with_a_naive_chain(seed: int) -> None:
    rng = np.random.default_rng(seed)
    wm = _tree_world(rng)
    params = json.loads(json.dumps(wm.params("G")))
    names = [ax["name"] for ax in params["axes"]]
    q = rng.uniform(-2.5, 2.5, size=(4, 3, 6))
    poses, ok = wm.link_poses("G", q)
    assert poses.shape == (4, 3, 7, 4, 4) and ok.shape == (4, 3)
    for i in range(4):
        for j in range(3):
            values = dict(zip(names, q[i, j], strict=True))
            np.testing.assert_allclose(poses[i, j, 0], _naive_matrix(params["pose"]), atol=1e-12)
            for k, name in enumerate(names):
                np.testing.assert_allclose(
                    poses[i, j, k + 1], _naive_frame(params, values, name), atol=1e-10
                )
            assert ok[i, j] == bool(np.all(np.abs(q[i, j]) <= 2.0))


def test_link_poses_agree_with_frame_pose() -> None:
    rng = np.random.default_rng(2)
    wm = _tree_world(rng)
    wm.axis_group_movej("G", [0.3, -0.4, 1.2, -1.9, 0.7, 1.1], 1, 1)
    _run(wm, 8.0, dt=0.1)
    poses, ok = wm.link_poses("G", wm.axis_group_get_actual_positions("G"))
    assert ok.shape == () and bool(ok)
    np.testing.assert_allclose(poses[0], wm.frame_pose("G"), atol=1e-12)
    for k in range(6):
        np.testing.assert_allclose(
            poses[k + 1], wm.frame_pose(wm.axis_group_get_axis_name(k)), atol=1e-12
        )


def test_link_poses_flags_out_of_limit_and_non_finite_positions() -> None:
    wm = _two_axis_example()
    q = np.array([[0.0, 3.0], [0.0, 3.0001], [math.nan, 0.0], [math.inf, 0.0], [-3.0, 0.0]])
    poses, ok = wm.link_poses("AxisGroup1", q)
    np.testing.assert_array_equal(ok, [True, False, False, False, True])
    assert np.all(np.isfinite(poses))


def test_a_linear_axis_moves_along_its_z() -> None:
    wm = WorldModel()
    wm.axis_group_add("G", [1, 0, 0, 0, 0, 0])
    wm.axis_group_add_axis("G", "slide", "", [0, 0, 0, 0, math.pi / 2, 0], 1, 1, 1)
    wm.axis_group_add_axis("G", "spin", "slide", [0, 0.1, 0, 0, 0, 0], 0, 1, 1)
    poses, _ = wm.link_poses("G", [0.25, math.pi / 2])
    # The slide's +Z is the world's +X: 0.25 m along it.
    np.testing.assert_allclose(poses[1, :3, 3], [1.25, 0, 0], atol=1e-12)
    np.testing.assert_allclose(poses[2, :3, 3], [1.25, 0.1, 0], atol=1e-12)
    np.testing.assert_allclose(poses[2, :3, 0], [0, 1, 0], atol=1e-12)


def test_params_survive_an_update_and_json() -> None:
    wm = _two_axis_example()
    wm.axis_group_update_axis("Axis1", pose=[0, 0, 1, 0, 0, 0], type=1, axis_index=0)
    params = json.loads(json.dumps(wm.params("AxisGroup1")))
    assert [ax["name"] for ax in params["axes"]] == ["Axis1", "Axis2"]
    first = params["axes"][0]
    assert first["type"] == 1 and first["axis_index"] == 0 and first["pose"][2] == 1.0
    poses, _ = wm.link_poses("AxisGroup1", [0.5, 0.0])
    expected = _naive_frame(params, {"Axis1": 0.5, "Axis2": 0.0}, "Axis1")
    np.testing.assert_allclose(poses[1], expected, atol=1e-12)


# -- simulated motion ----------------------------------------------------------------------


def test_actual_follows_target_within_limits() -> None:
    wm = _two_axis_example()
    wm.axis_group_update_axis("Axis1", v_limit=0.5, a_limit=2.0)
    wm.axis_group_movej("AxisGroup1", [1.0, -2.0], 0.5, 1)
    target = wm.axis_group_get_target_positions("AxisGroup1")
    dt = 0.01
    trace = [wm.axis_group_get_actual_positions("AxisGroup1")]
    while wm.is_moving("AxisGroup1"):
        wm.advance(dt)
        trace.append(wm.axis_group_get_actual_positions("AxisGroup1"))
    path = np.array(trace)
    np.testing.assert_array_equal(path[-1], target)
    vel = np.diff(path, axis=0) / dt
    assert np.all(np.abs(vel) <= np.array([1.0, 0.5]) + 1e-9)
    acc = np.diff(path, 2, axis=0) / dt**2
    # a = 0.5 scales both acceleration limits (1 and 2) by half.
    assert np.all(np.abs(acc[1:-1]) <= np.array([0.5, 1.0]) * (1 + 1e-6) + 1e-6)
    # Both axes arrive on the same tick.
    at_target = np.isclose(path, target, atol=1e-12)
    assert np.argmax(at_target[:, 0]) == np.argmax(at_target[:, 1])


def test_movej_clips_targets_to_the_limits() -> None:
    wm = _two_axis_example()
    wm.axis_group_movej("AxisGroup1", [10.0, -10.0], 1, 1)
    np.testing.assert_array_equal(wm.axis_group_get_target_positions("AxisGroup1"), [3.0, -3.0])
