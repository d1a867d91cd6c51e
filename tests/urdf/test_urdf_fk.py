"""URDF forward kinematics against two independent implementations, on every link.

roboticstoolbox reads the fixtures itself and treats a mimic joint as a joint
of its own, so it gets the mimic's value worked out here from yourdfpy's
parse; it cannot turn about axes other than +-x, +-y, +-z, so the fixture with
such axes is compared with yourdfpy's own forward kinematics (which follows
mimics and any axis) instead. Every kernel is checked: one configuration,
small batches, and large batches in the column kernel.
"""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np
import pytest
import roboticstoolbox as rtb
import yourdfpy
from lxml import etree

from server.urdf import UrdfRobot, load_urdf

FIXTURES = Path(__file__).parent / "fixtures"
MESH_PACKAGES = {"mesh_description": FIXTURES / "mesh_description"}
SERIAL6 = FIXTURES / "serial6.urdf"
LIFT_GRIPPER = FIXTURES / "lift_gripper.urdf"
MESH_ARM = FIXTURES / "mesh_description" / "urdf" / "mesh_arm.urdf"
ARM6 = Path(__file__).parents[2] / "cells" / "examples" / "arm6" / "arm6_description" / "urdf"
TOL = 1e-9


def random_q(robot: UrdfRobot, count: int, seed: int) -> np.ndarray:
    """Joint values within the limits (continuous joints over +-2 turns)."""
    lim = np.where(np.isfinite(robot.limits), robot.limits, [-4 * np.pi, 4 * np.pi])
    return np.random.default_rng(seed).uniform(lim[:, 0], lim[:, 1], (count, robot.chain.n_joints))


def joint_values(parsed: yourdfpy.URDF, robot: UrdfRobot, q: np.ndarray) -> dict[str, float]:
    """Every moving joint's value, keyed by its child link, mimics worked out from the URDF."""
    by_name = dict(zip(robot.joint_names, q.tolist(), strict=True))
    out = {}
    for joint in parsed.robot.joints:
        if joint.type == "fixed":
            continue
        if joint.mimic is None:
            out[joint.child] = by_name[joint.name]
        else:
            out[joint.child] = (
                joint.mimic.multiplier * by_name[joint.mimic.joint] + joint.mimic.offset
            )
    return out


def rtb_poses(path: Path, robot: UrdfRobot, q: np.ndarray) -> np.ndarray:
    """Poses ``(m, links, 4, 4)`` by roboticstoolbox, in ``robot.link_names`` order."""
    # Kinematics only: roboticstoolbox would otherwise load the meshes too.
    root = etree.parse(str(path)).getroot()
    for el in root.findall("link/visual") + root.findall("link/collision"):
        el.getparent().remove(el)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from roboticstoolbox.models.URDF.URDFRobot import URDF_file

        elinks, name, _ = URDF_file(io.StringIO(etree.tostring(root, encoding="unicode")))
        model = rtb.Robot(elinks, name=name)
    parsed = yourdfpy.URDF.load(str(path), build_scene_graph=False, load_meshes=False)
    out = np.empty((len(q), len(robot.link_names), 4, 4))
    for k, row in enumerate(q):
        values = joint_values(parsed, robot, row)
        q_rtb = np.zeros(model.n)
        for link in model.links:
            if link.isjoint:
                q_rtb[link.jindex] = values[link.name]
        for i, link_name in enumerate(robot.link_names):
            out[k, i] = model.fkine(q_rtb, end=link_name).A
    return out


def yourdfpy_poses(path: Path, robot: UrdfRobot, q: np.ndarray) -> np.ndarray:
    """Poses ``(m, links, 4, 4)`` by yourdfpy's scene graph, in ``robot.link_names`` order."""
    parsed = yourdfpy.URDF.load(str(path), load_meshes=False)
    root = robot.link_names[0]
    out = np.empty((len(q), len(robot.link_names), 4, 4))
    for k, row in enumerate(q):
        parsed.update_cfg(row)
        for i, link in enumerate(robot.link_names):
            out[k, i] = parsed.get_transform(link, root)
    return out


def check_every_kernel(robot: UrdfRobot, q: np.ndarray, expected: np.ndarray) -> None:
    """One configuration at a time, a small batch, and the same rows inside a large batch."""
    for row, want in zip(q[:10], expected[:10], strict=True):
        got, ok = robot.chain.link_poses(row)
        assert bool(ok)
        np.testing.assert_allclose(got, want, rtol=0, atol=TOL)
    small, ok = robot.chain.link_poses(q)
    assert ok.all() and small.shape == expected.shape
    np.testing.assert_allclose(small, expected, rtol=0, atol=TOL)
    # Above the column kernel's threshold, not a multiple of its block; the rows checked sit
    # in the first and the last block.
    filler = random_q(robot, 9000, seed=99)
    big = np.concatenate([q, filler, q])
    large, ok = robot.chain.link_poses(big)
    assert ok.all()
    np.testing.assert_allclose(large[: len(q)], expected, rtol=0, atol=TOL)
    np.testing.assert_allclose(large[-len(q) :], expected, rtol=0, atol=TOL)
    tip = robot.link_names.index(robot.chain.tip)
    for batch in (q, big):
        flange, _ = robot.chain.forward(batch)
        np.testing.assert_allclose(flange[: len(q)], expected[:, tip], rtol=0, atol=TOL)
    one, _ = robot.chain.forward(q[0])
    np.testing.assert_allclose(one, expected[0, tip], rtol=0, atol=TOL)


@pytest.mark.parametrize("path", [SERIAL6, LIFT_GRIPPER, ARM6 / "arm6.urdf"], ids=lambda p: p.stem)
def test_every_link_agrees_with_roboticstoolbox(path: Path) -> None:
    robot = load_urdf(path, {"arm6_description": ARM6.parent})
    q = random_q(robot, 60, seed=1)
    check_every_kernel(robot, q, rtb_poses(path, robot, q))


@pytest.mark.parametrize("path", [SERIAL6, LIFT_GRIPPER, MESH_ARM], ids=lambda p: p.stem)
def test_every_link_agrees_with_yourdfpy(path: Path) -> None:
    robot = load_urdf(path, MESH_PACKAGES)
    q = random_q(robot, 60, seed=2)
    check_every_kernel(robot, q, yourdfpy_poses(path, robot, q))


def test_mimic_joints_follow_their_leader() -> None:
    robot = load_urdf(LIFT_GRIPPER)
    assert robot.joint_names == ("lift", "shoulder", "elbow", "wrist_joint", "finger_left_joint")
    q = np.array([0.3, 0.5, 0.8, -0.4, 0.03])
    poses, _ = robot.chain.link_poses(q)
    at = {name: poses[i] for i, name in enumerate(robot.link_names)}
    # The fingers open symmetrically in the palm frame: right moves -0.03 along y.
    in_palm = np.linalg.inv(at["palm"]) @ at["finger_right"]
    np.testing.assert_allclose(in_palm[:3, 3], [0.0, -0.01 - 0.03, 0.04], atol=1e-12)
    # The flap turns about its y by 0.5 * elbow + 0.1 from its origin's pitch of 0.3.
    in_upper = np.linalg.inv(at["upper"]) @ at["flap"]
    pitch = 0.3 + 0.5 * 0.8 + 0.1
    np.testing.assert_allclose(
        in_upper[:3, :3][[0, 0, 2, 2], [0, 2, 0, 2]],
        [np.cos(pitch), np.sin(pitch), -np.sin(pitch), np.cos(pitch)],
        atol=1e-12,
    )
