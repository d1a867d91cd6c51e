"""UrdfChain on trees built in code: random trees against a plain reference, checks, inverse.

The reference below composes each link's pose as URDF states it, one 4x4
product per joint, with scipy's rotations: nothing shared with the kernels.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from server.kinematics import UrdfChain, UrdfJoint, UrdfMimic, UrdfTree

TOL = 1e-9


def pose(xyz: tuple[float, float, float], rpy: tuple[float, float, float]) -> np.ndarray:
    """URDF origin: rotation R = Rz(yaw) Ry(pitch) Rx(roll), then translation xyz."""
    out = np.eye(4)
    out[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()
    out[:3, 3] = xyz
    return out


def reference(tree: UrdfTree, q: np.ndarray) -> dict[str, np.ndarray]:
    """Every link's pose in the root frame for one configuration, straight from the URDF rules."""
    joints = {j.name: j for j in tree.joints}
    movable = [j.name for j in tree.joints if j.type != "fixed" and j.mimic is None]
    given = dict(zip(movable, q.tolist(), strict=True))

    def value(joint: UrdfJoint) -> float:
        if joint.mimic is None:
            return given[joint.name]
        leader = value(joints[joint.mimic.joint])
        return joint.mimic.multiplier * leader + joint.mimic.offset

    children = {j.child for j in tree.joints}
    poses = {link: np.eye(4) for link in tree.links if link not in children}
    while len(poses) < len(tree.links):
        for joint in tree.joints:
            if joint.parent in poses and joint.child not in poses:
                motion = np.eye(4)
                axis = np.asarray(joint.axis) / np.linalg.norm(joint.axis)
                if joint.type in ("revolute", "continuous"):
                    motion[:3, :3] = Rotation.from_rotvec(axis * value(joint)).as_matrix()
                elif joint.type == "prismatic":
                    motion[:3, 3] = axis * value(joint)
                poses[joint.child] = poses[joint.parent] @ joint.origin @ motion
    return poses


def random_tree(rng: np.random.Generator, n_links: int) -> UrdfTree:
    """A random tree: any joint type, quarter-turn or arbitrary origins, any axis, mimics."""
    links = [f"link{i}" for i in range(n_links)]
    joints: list[UrdfJoint] = []
    for i in range(1, n_links):
        kind = str(
            rng.choice(["revolute", "continuous", "prismatic", "fixed"], p=[0.45, 0.15, 0.2, 0.2])
        )
        if rng.random() < 0.5:
            rpy = tuple(float(x) for x in rng.integers(-2, 3, 3) * (math.pi / 2))
        else:
            rpy = tuple(float(x) for x in rng.uniform(-math.pi, math.pi, 3))
        xyz = tuple(float(x) * (rng.random() < 0.7) for x in rng.uniform(-0.4, 0.4, 3))
        if rng.random() < 0.6:
            axis = np.zeros(3)
            axis[rng.integers(3)] = rng.choice([-1.0, 1.0])
        else:
            axis = rng.normal(size=3) * rng.uniform(0.5, 2.0)  # not unit length on purpose
        leaders = [j.name for j in joints if j.type != "fixed"]
        mimic = None
        if kind != "fixed" and leaders and rng.random() < 0.3:
            mimic = UrdfMimic(
                str(rng.choice(leaders)), float(rng.uniform(-2, 2)), float(rng.uniform(-0.3, 0.3))
            )
        joints.append(
            UrdfJoint(
                name=f"joint{i}",
                type=kind,  # type: ignore[arg-type]
                parent=links[int(rng.integers(i))] if rng.random() < 0.4 else links[i - 1],
                child=links[i],
                origin=pose(xyz, rpy),  # type: ignore[arg-type]
                axis=(float(axis[0]), float(axis[1]), float(axis[2])),
                limits=(-2.5, 2.5) if kind == "revolute" else (-0.3, 0.5),
                mimic=mimic,
            )
        )
    order = rng.permutation(n_links)  # the document may list links in any order
    return UrdfTree(tuple(links[i] for i in order), tuple(joints))


def ur_like() -> UrdfTree:
    """A UR5-like 6-axis arm (classic ur_description frames) with a tool0 frame."""
    half = math.pi / 2
    rows = [
        ("base_link", "shoulder", (0, 0, 0.089159), (0, 0, 0), (0, 0, 1)),
        ("shoulder", "upper_arm", (0, 0.13585, 0), (0, half, 0), (0, 1, 0)),
        ("upper_arm", "forearm", (0, -0.1197, 0.425), (0, 0, 0), (0, 1, 0)),
        ("forearm", "wrist_1", (0, 0, 0.39225), (0, half, 0), (0, 1, 0)),
        ("wrist_1", "wrist_2", (0, 0.093, 0), (0, 0, 0), (0, 0, 1)),
        ("wrist_2", "wrist_3", (0, 0, 0.09465), (0, 0, 0), (0, 1, 0)),
    ]
    joints = [
        UrdfJoint(f"j{i}", "revolute", p, c, pose(xyz, rpy), axis, limits=(-math.pi, math.pi))
        for i, (p, c, xyz, rpy, axis) in enumerate(rows)
    ]
    joints.append(
        UrdfJoint("tool", "fixed", "wrist_3", "tool0", pose((0, 0.0823, 0), (-half, 0, 0)))
    )
    links = ("base_link",) + tuple(r[1] for r in rows) + ("tool0",)
    return UrdfTree(links, tuple(joints))


def gripper_arm() -> UrdfTree:
    """Lift (prismatic), continuous shoulder, elbow, wrist; two fingers, the right one a mimic."""
    return UrdfTree(
        ("base", "carriage", "upper", "fore", "palm", "left", "right"),
        (
            UrdfJoint(
                "lift",
                "prismatic",
                "base",
                "carriage",
                pose((0.1, 0, 0.2), (0, 0, 0.3)),
                (0, 0, 1),
                (0.0, 0.6),
            ),
            UrdfJoint(
                "shoulder",
                "continuous",
                "carriage",
                "upper",
                pose((0, 0.1, 0.05), (0, 0, 0)),
                (0, 0, 1),
            ),
            UrdfJoint(
                "elbow",
                "revolute",
                "upper",
                "fore",
                pose((0.4, 0, 0), (0.2, 0, 0)),
                (0, 0, 1),
                (-2.6, 2.6),
            ),
            UrdfJoint(
                "wrist",
                "revolute",
                "fore",
                "palm",
                pose((0.3, 0, -0.02), (math.pi, 0.4, 0)),
                (1, 0, 0),
                (-3.0, 3.0),
            ),
            UrdfJoint(
                "left_finger",
                "prismatic",
                "palm",
                "left",
                pose((0.05, 0.01, 0), (0, 0, 0)),
                (0, 1, 0),
                (0.0, 0.04),
            ),
            UrdfJoint(
                "right_finger",
                "prismatic",
                "palm",
                "right",
                pose((0.05, -0.01, 0.02), (0, 0.5, 0)),
                (0, 1, 0),
                (-0.04, 0.0),
                UrdfMimic("left_finger", -1.0, 0.0),
            ),
        ),
    )


def within(chain: UrdfChain, q: np.ndarray) -> bool:
    return bool(np.all((q >= chain.limits[:, 0] - 1e-12) & (q <= chain.limits[:, 1] + 1e-12)))


@pytest.mark.parametrize("seed", range(40))
def test_random_trees_agree_with_the_reference_on_every_kernel(seed: int) -> None:
    rng = np.random.default_rng(seed)
    tree = random_tree(rng, int(rng.integers(2, 11)))
    chain = UrdfChain(tree)
    q = rng.uniform(-3, 3, (300, chain.n_joints))  # above the column kernel's threshold
    expected = np.array(
        [
            [ref[name] for name in chain.link_names]
            for ref in (reference(tree, row) for row in q[:12])
        ]
    )
    large, ok = chain.link_poses(q)
    small, _ = chain.link_poses(q[:12])
    assert ok.all()
    np.testing.assert_allclose(large[:12], expected, rtol=0, atol=TOL)
    np.testing.assert_allclose(small, expected, rtol=0, atol=TOL)
    for row, want in zip(q[:12], expected, strict=True):
        one, ok_one = chain.link_poses(row)
        assert bool(ok_one)
        np.testing.assert_allclose(one, want, rtol=0, atol=TOL)
    tip = chain.link_names.index(chain.tip)
    np.testing.assert_allclose(chain.forward(q)[0][:12], expected[:, tip], rtol=0, atol=TOL)
    np.testing.assert_allclose(chain.forward(q[0])[0], expected[0, tip], rtol=0, atol=TOL)


def test_large_batches_match_small_ones_across_blocks_and_leading_axes() -> None:
    rng = np.random.default_rng(3)
    chain = UrdfChain(random_tree(rng, 9))
    # 9003 rows: three blocks of the column kernel.
    q = rng.uniform(-3, 3, (3, 3001, chain.n_joints))
    large, ok = chain.link_poses(q)
    assert (
        large.shape == (3, 3001, len(chain.link_names), 4, 4) and ok.shape == (3, 3001) and ok.all()
    )
    flat = q.reshape(-1, chain.n_joints)
    pieces = np.concatenate(
        [chain.link_poses(flat[i : i + 200])[0] for i in range(0, len(flat), 200)]
    )
    np.testing.assert_allclose(large.reshape(pieces.shape), pieces, rtol=0, atol=1e-12)


def test_links_come_root_first_and_joints_in_document_order() -> None:
    tree = gripper_arm()
    shuffled = UrdfTree(
        ("right", "palm", "left", "fore", "base", "upper", "carriage"), tree.joints[::-1]
    )
    chain = UrdfChain(shuffled)
    names = chain.link_names
    assert names[0] == "base" and set(names) == set(tree.links)
    parents = {j.child: j.parent for j in tree.joints}
    assert all(names.index(parents[link]) < names.index(link) for link in names[1:])
    # Movable, non-mimic joints in the order the description lists them.
    assert UrdfChain(tree).joint_names == ("lift", "shoulder", "elbow", "wrist", "left_finger")
    assert chain.joint_names == ("left_finger", "wrist", "elbow", "shoulder", "lift")


def test_defaults_units_limits_and_params() -> None:
    chain = UrdfChain(gripper_arm())
    assert chain.n_joints == 5
    assert chain.tip == "left"  # the deepest links tie; the first listed wins
    assert UrdfChain(gripper_arm(), tip="fore").tip == "fore"
    assert chain.joint_units == ("m", "rad", "rad", "rad", "m")
    assert chain.limits[1].tolist() == [-math.inf, math.inf]  # continuous
    np.testing.assert_array_equal(
        chain.limits[[0, 2, 3, 4]], [[0, 0.6], [-2.6, 2.6], [-3, 3], [0, 0.04]]
    )
    params = json.loads(json.dumps(chain.params()))
    assert params["joint_names"] == list(chain.joint_names)
    assert params["joint_types"] == ["prismatic", "continuous", "revolute", "revolute", "prismatic"]
    assert params["limits"][1] == [None, None] and params["tip"] == "left"
    assert params["link_names"] == list(chain.link_names)
    with pytest.raises(ValueError, match="no link named 'hand'"):
        UrdfChain(gripper_arm(), tip="hand")


def test_non_finite_joints_are_not_ok_and_poses_stay_finite() -> None:
    chain = UrdfChain(ur_like())
    q = np.zeros((300, 6))
    q[5, 2], q[7, 0] = np.nan, np.inf
    for batch in (q, q[:10]):
        poses, ok = chain.link_poses(batch)
        assert np.isfinite(poses).all()
        assert ok.tolist() == [i not in (5, 7) for i in range(len(batch))]
    one, ok_one = chain.link_poses(q[5])
    assert not bool(ok_one) and np.isfinite(one).all()
    np.testing.assert_allclose(one, chain.link_poses(np.zeros(6))[0], atol=0)
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 6\)"):
        chain.link_poses(np.zeros(5))


def bad(tree: UrdfTree, **changes: object) -> UrdfTree:
    joints = list(tree.joints)
    name = changes.pop("joint", "elbow")
    index = next(i for i, j in enumerate(joints) if j.name == name)
    fields = {**vars(joints[index]), **changes}
    joints[index] = UrdfJoint(**fields)  # type: ignore[arg-type]
    return UrdfTree(tree.links, tuple(joints))


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"type": "floating"}, "joint 'elbow' has type 'floating'; supported types are revolute"),
        ({"parent": "nowhere"}, "joint 'elbow': its parent link 'nowhere' is not defined"),
        ({"child": "upper"}, "joint 'elbow' connects link 'upper' to itself"),
        ({"limits": None}, "joint 'elbow' .revolute. needs limits"),
        ({"limits": (1.0, -1.0)}, "limits must be finite with lower <= upper"),
        ({"axis": (0.0, 0.0, 0.0)}, "joint 'elbow': axis must be a non-zero 3-vector"),
        (
            {"mimic": UrdfMimic("knee")},
            "joint 'elbow' mimics 'knee', which is not a joint of this robot",
        ),
        (
            {"joint": "right_finger", "mimic": UrdfMimic("right_finger")},
            "mimic joints form a cycle",
        ),
    ],
)
def test_bad_trees_are_rejected_with_what_is_wrong(
    changes: dict[str, object], message: str
) -> None:
    with pytest.raises(ValueError, match=message):
        UrdfChain(bad(gripper_arm(), **changes))


def test_bad_tree_shapes_are_rejected() -> None:
    tree = gripper_arm()
    with pytest.raises(ValueError, match="two links are named 'base'"):
        UrdfChain(UrdfTree(tree.links + ("base",), tree.joints))
    with pytest.raises(ValueError, match="single root link; roots found: base, spare"):
        UrdfChain(UrdfTree(tree.links + ("spare",), tree.joints))
    with pytest.raises(ValueError, match="link 'fore' is the child of two joints"):
        extra = UrdfJoint("again", "fixed", "base", "fore")
        UrdfChain(UrdfTree(tree.links, tree.joints + (extra,)))
    loop = UrdfJoint("loop", "fixed", "right", "base")
    with pytest.raises(ValueError, match="roots found: none"):
        UrdfChain(UrdfTree(tree.links, tree.joints + (loop,)))
    fixed_leader = bad(tree, joint="left_finger", type="fixed")
    with pytest.raises(ValueError, match="mimics 'left_finger', which is a fixed joint"):
        UrdfChain(fixed_leader)


def test_mimic_of_a_mimic_composes() -> None:
    tree = gripper_arm()
    thumb = UrdfJoint(
        "thumb",
        "revolute",
        "palm",
        "thumb_link",
        pose((0, 0, 0.05), (0, 0, 0)),
        (0, 0, 1),
        mimic=UrdfMimic("right_finger", 10.0, 0.2),
    )
    chain = UrdfChain(UrdfTree(tree.links + ("thumb_link",), tree.joints + (thumb,)))
    q = np.array([0.1, 0.2, 0.3, 0.4, 0.03])
    poses, _ = chain.link_poses(q)
    at = dict(zip(chain.link_names, poses, strict=True))
    turn = np.linalg.inv(at["palm"]) @ at["thumb_link"]
    angle = 10.0 * (-1.0 * 0.03) + 0.2  # thumb = 10 * right + 0.2, right = -left
    np.testing.assert_allclose(
        turn[:2, :2],
        [[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]],
        atol=1e-12,
    )


def round_trip(chain: UrdfChain, seed: int, count: int) -> None:
    rng = np.random.default_rng(seed)
    lim = np.where(np.isfinite(chain.limits), chain.limits, [-math.pi, math.pi])
    q_true = rng.uniform(0.8 * lim[:, 0], 0.8 * lim[:, 1], (count, chain.n_joints))
    targets, _ = chain.forward(q_true)
    q_ref = rng.uniform(lim[:, 0], lim[:, 1], (count, chain.n_joints))
    q, ok = chain.inverse(targets, q_ref)
    assert ok.all()
    np.testing.assert_allclose(chain.forward(q)[0], targets, rtol=0, atol=1e-9)
    assert within(chain, q)


def test_inverse_round_trips_a_six_axis_arm() -> None:
    round_trip(UrdfChain(ur_like()), seed=4, count=40)


def test_inverse_round_trips_prismatic_continuous_and_mimic_joints() -> None:
    # The tip is the right finger: its pose depends on the left finger through the mimic.
    chain = UrdfChain(gripper_arm(), tip="right")
    round_trip(chain, seed=5, count=30)
    # The continuous joint's answer stays within half a turn of the reference.
    q_true = np.array([0.2, 2.5, 0.4, -0.3, 0.02])
    q_ref = q_true + np.array([0.0, 6.0, 0.0, 0.0, 0.0])  # about one turn away
    q, ok = chain.inverse(chain.forward(q_true)[0], q_ref)
    assert bool(ok) and abs(q[1] - q_ref[1]) <= math.pi
    np.testing.assert_allclose(chain.forward(q)[0], chain.forward(q_true)[0], atol=1e-9)


def test_inverse_keeps_joints_that_do_not_move_the_tip() -> None:
    chain = UrdfChain(gripper_arm(), tip="palm")
    q_true = np.array([0.3, 1.0, -0.5, 0.7, 0.01])
    q_ref = np.array([0.25, 0.8, -0.4, 0.5, 0.035])
    q, ok = chain.inverse(chain.forward(q_true)[0], q_ref)
    assert bool(ok) and q[4] == q_ref[4]
    np.testing.assert_allclose(chain.forward(q)[0], chain.forward(q_true)[0], atol=1e-9)


def test_inverse_prefers_the_reference_and_is_deterministic() -> None:
    chain = UrdfChain(ur_like())
    q_true = np.array([0.3, -1.0, 1.2, -0.5, 0.8, 0.2])
    q, ok = chain.inverse(chain.forward(q_true)[0], q_true)
    assert bool(ok)
    np.testing.assert_allclose(q, q_true, atol=1e-9)
    target = chain.forward(np.array([1.0, -0.5, 0.7, 0.1, -1.2, 2.0]))[0]
    first, second = chain.inverse(target), chain.inverse(target)
    np.testing.assert_array_equal(first[0], second[0])


def test_inverse_fails_cleanly_and_keeps_batch_shapes() -> None:
    chain = UrdfChain(ur_like())
    reachable = chain.forward(np.array([0.3, -1.0, 1.2, -0.5, 0.8, 0.2]))[0]
    far = pose((3.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    invalid = np.full((4, 4), np.nan)
    targets = np.stack([reachable, far, invalid]).reshape(3, 1, 4, 4)
    q_ref = np.full(6, 5.0)  # outside the limits: clipped where nothing converges
    q, ok = chain.inverse(targets, q_ref)
    assert q.shape == (3, 1, 6) and ok.shape == (3, 1)
    assert ok[:, 0].tolist() == [True, False, False]
    np.testing.assert_allclose(q[1:, 0], np.full((2, 6), math.pi))
    with pytest.raises(ValueError, match=r"pose must have shape \(\.\.\., 4, 4\)"):
        chain.inverse(np.eye(3))


def test_a_robot_without_movable_joints() -> None:
    tree = UrdfTree(("a", "b"), (UrdfJoint("ab", "fixed", "a", "b", pose((0, 0, 1), (0, 0, 0))),))
    chain = UrdfChain(tree)
    assert chain.n_joints == 0 and chain.tip == "b"
    one, ok = chain.forward(np.zeros(0))
    assert bool(ok) and one[2, 3] == 1.0
    assert chain.link_poses(np.zeros((300, 0)))[0].shape == (300, 2, 4, 4)
    _, solved = chain.inverse(np.stack([one, pose((0, 0, 2), (0, 0, 0))]))
    assert solved.tolist() == [True, False]
