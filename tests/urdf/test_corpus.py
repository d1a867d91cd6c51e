"""Every published robot description of the corpus loads, moves like pinocchio says, and draws.

For each robot of ``tests/urdf/corpus.py``: ``check`` passes on a cell holding
them all; the pose of every link agrees with pinocchio (its own URDF parser,
urdfdom, and its own kinematics; xacro files as the ``xacro`` command prints
them) on 50 random configurations within the limits, to 1e-9 m and 1e-9 rad;
every mesh converts to a GLB with triangles.
The browser test ``tests/web/test_browser_corpus.py`` looks at them on the page.
"""

from __future__ import annotations

import math
import zlib
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import numpy.typing as npt
import pinocchio as pin
import pytest
import trimesh

from server.kinematics.urdf import UrdfChain
from server.urdf import link_meshes, load_urdf
from server.urdf._paths import Packages
from server.urdf._xacro import expand, is_xacro
from server.urdf._xml import parse, uses_xacro
from tests.test_cli import run_server
from tests.urdf.corpus import CORPUS, Described
from tests.urdf.real_xacro import real_xacro

CONFIGS = 50
MIMIC_FIXTURE = Path(__file__).parent / "fixtures" / "lift_gripper.urdf"
TOL_M = 1e-9
TOL_RAD = 1e-9
FREE_RANGE = math.pi  # rad or m drawn for joints without limits
IDS = [robot.name for robot in CORPUS]


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One mesh cache for the module: the check runs on what the conversions left."""
    return tmp_path_factory.mktemp("corpus-cache")


def test_the_corpus_has_what_the_issue_asks() -> None:
    assert len(CORPUS) >= 15 and len({r.name for r in CORPUS}) == len(CORPUS)
    assert len({robot.module for robot in CORPUS}) >= 3
    has = {feature for robot in CORPUS for feature in robot.features}
    assert {"industrial", "dae", "7-axis", "mimic", "floating base", "xacro"} <= has
    arm = [r for r in CORPUS if {"6-axis", "industrial", "dae"} <= set(r.features)]
    assert arm and all(r.path.is_file() for r in CORPUS)
    assert any({"7-axis", "mimic"} <= set(r.features) for r in CORPUS)


def test_the_corpus_has_machines_past_the_old_cap_of_32_joints() -> None:
    # Issue 31: humanoids and mobile manipulators were refused for more than 32 joints.
    large = {
        r.name: r
        for r in CORPUS
        if {"more than 32 joints", "more than 60 joints"} & set(r.features)
    }
    counts = {
        name: len(load_urdf(r.path, r.package_folders).joint_names) for name, r in large.items()
    }
    assert sum(n > 32 for n in counts.values()) >= 2 and max(counts.values()) > 60, counts


def needs_xacro(robot: Described) -> bool:
    """True for a xacro file, or a URDF that still holds xacro."""
    return is_xacro(robot.path) or uses_xacro(parse(robot.path.read_bytes(), str(robot.path)))


def pinocchio_model(robot: Described) -> pin.Model:
    """pinocchio's model of the same file (xacro expanded by the xacro package), mimics followed."""
    if needs_xacro(robot):
        expanded = real_xacro(robot.path, robot.args, robot.package_folders)
        return pin.buildModelFromXML(expanded.stdout, mimic=True)
    return pin.buildModelFromUrdf(str(robot.path), mimic=True)


@pytest.mark.parametrize("robot", [r for r in CORPUS if needs_xacro(r)], ids=lambda r: r.name)
def test_xacro_files_expand_to_the_xacro_commands_text(robot: Described) -> None:
    # The sandboxed worker (no eval, confined reads) loses nothing of a published file.
    theirs = real_xacro(robot.path, robot.args, robot.package_folders)
    assert theirs.returncode == 0, theirs.stderr
    packages = Packages(robot.package_folders, robot.path.parent)
    assert expand(robot.path, robot.args, packages).text == theirs.stdout


def rotation_angle(a: npt.NDArray[np.float64], b: npt.NDArray[np.float64]) -> float:
    """The angle (rad) of the turn from ``a`` to ``b``, accurate near 0."""
    m = a.T @ b
    s = np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]]) / 2
    return math.atan2(float(np.linalg.norm(s)), (np.trace(m) - 1) / 2)


@pytest.mark.parametrize("robot", CORPUS, ids=IDS)
def test_every_link_moves_as_pinocchio_says(robot: Described) -> None:
    ours = load_urdf(robot.path, robot.package_folders, args=robot.args)
    assert ours.warnings == (), ours.warnings
    assert_moves_as_pinocchio_says(ours.chain, pinocchio_model(robot), robot.name)


def test_mimic_multipliers_and_offsets_move_as_pinocchio_says() -> None:
    # No published description of the corpus has a mimic offset (all are 0): the fixture's
    # flap follows its elbow with multiplier 0.5 and offset 0.1 rad.
    mimics = [m.attrib for m in ElementTree.parse(MIMIC_FIXTURE).iter("mimic")]
    assert {"joint": "elbow", "multiplier": "0.5", "offset": "0.1"} in mimics
    ours = load_urdf(MIMIC_FIXTURE)
    model = pin.buildModelFromUrdf(str(MIMIC_FIXTURE), mimic=True)
    assert_moves_as_pinocchio_says(ours.chain, model, MIMIC_FIXTURE.name)


def assert_moves_as_pinocchio_says(chain: UrdfChain, model: pin.Model, seed: str) -> None:
    """Every link's pose agrees with pinocchio's on CONFIGS random configurations."""
    data = model.createData()
    moving = {model.names[i] for i, j in enumerate(model.joints) if i > 0 and j.nq > 0}
    assert set(chain.joint_names) == moving
    frames = [model.getFrameId(name, pin.BODY) for name in chain.link_names]
    assert all(f < len(model.frames) for f in frames), "a link pinocchio does not know"

    rng = np.random.default_rng(zlib.crc32(seed.encode()))
    lo = np.where(np.isfinite(chain.limits[:, 0]), chain.limits[:, 0], -FREE_RANGE)
    hi = np.where(np.isfinite(chain.limits[:, 1]), chain.limits[:, 1], FREE_RANGE)
    qs = rng.uniform(lo, hi, (CONFIGS, chain.n_joints))
    batch, ok = chain.link_poses(qs)
    assert ok.all()
    worst_m = worst_rad = 0.0
    for q, poses in zip(qs, batch, strict=True):
        one, _ = chain.link_poses(q)  # the server's per-frame path
        np.testing.assert_array_equal(one.shape, poses.shape)
        q_pin = pin.neutral(model)
        for name, value in zip(chain.joint_names, q, strict=True):
            joint = model.joints[model.getJointId(name)]
            if joint.nq == 2:  # continuous: cos, sin
                q_pin[joint.idx_q : joint.idx_q + 2] = math.cos(value), math.sin(value)
            else:
                q_pin[joint.idx_q] = value
        pin.framesForwardKinematics(model, data, q_pin)
        for k, frame in enumerate(frames):
            theirs = data.oMf[frame]
            for mine in (poses[k], one[k]):
                worst_m = max(worst_m, float(np.abs(mine[:3, 3] - theirs.translation).max()))
                worst_rad = max(worst_rad, rotation_angle(mine[:3, :3], theirs.rotation))
    assert worst_m <= TOL_M and worst_rad <= TOL_RAD, (worst_m, worst_rad)


@pytest.mark.parametrize("robot", CORPUS, ids=IDS)
def test_every_mesh_converts(robot: Described, cache: Path) -> None:
    loaded = load_urdf(robot.path, robot.package_folders, args=robot.args)
    meshes = link_meshes(loaded, cache)
    assert meshes.warnings == ()
    assert set(meshes.files) == {link for link, visuals in loaded.visuals.items() if visuals}
    assert len(meshes.files) >= 1
    for path in meshes.files.values():
        scene = trimesh.load(path, force="scene")
        assert sum(len(g.faces) for g in scene.geometry.values()) > 0, path


def test_check_passes_on_a_cell_of_the_whole_corpus(tmp_path: Path, cache: Path) -> None:
    parts = ['[[source]]\nname = "mock"\n']
    for robot in CORPUS:
        chain = load_urdf(robot.path, robot.package_folders, args=robot.args).chain
        joints = ", ".join(
            f'{{ node = "{robot.name}/j{k}", unit = "{unit}" }}'
            for k, unit in enumerate(chain.joint_units)
        )
        packages = ", ".join(f'{k} = "{v}"' for k, v in robot.package_folders.items())
        args = ", ".join(f'{k} = "{v}"' for k, v in robot.args.items())
        parts.append(
            f'[[robot]]\nname = "{robot.name}"\nsource = "mock"\n'
            f'kinematics = {{ type = "urdf", file = "{robot.path}", '
            f"packages = {{ {packages} }}, args = {{ {args} }} }}\n"
            f"joints = [{joints}]\n"
        )
    cell = tmp_path / "corpus.toml"
    cell.write_text("\n".join(parts))
    result = run_server("check", str(cell), env={"LINKVIEW_CACHE_DIR": str(cache)})
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert len(lines) == len(CORPUS) and "warning" not in result.stdout, result.stdout
    for robot, line in zip(CORPUS, lines, strict=True):
        assert line.startswith(f"{cell}: {robot.name}: urdf, "), line


def test_a_legged_robot_on_a_floating_root(tmp_path: Path) -> None:
    # As a simulation scene puts it into a world: the vendor's file included unchanged
    # (its relative mesh paths still resolve from its own folder), its trunk hung from
    # the world by a floating joint. The vendor's folder is a package the cell names: a
    # description reads only its own folder, the cell's and its packages.
    a1 = next(robot for robot in CORPUS if robot.name == "a1")
    packages = {"a1_description": a1.path.parent}
    scene = tmp_path / "a1_in_world.urdf.xacro"
    scene.write_text(
        '<robot name="a1_world" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        '  <link name="world"/>\n'
        '  <joint name="world_to_trunk" type="floating">\n'
        '    <parent link="world"/><child link="trunk"/>\n'
        '    <origin xyz="0.2 0.1 0.35" rpy="0 0 0.5"/>\n'
        "  </joint>\n"
        f'  <xacro:include filename="$(find a1_description)/{a1.path.name}"/>\n'
        "</robot>\n"
    )
    robot = load_urdf(scene, packages)
    (warning,) = robot.warnings
    # The line the xacro command prints the joint on (after its banner).
    urdf = real_xacro(scene, {}, packages).stdout
    line = next(i for i, text in enumerate(urdf.splitlines(), 1) if "world_to_trunk" in text)
    assert warning.startswith(f"{scene}, line {line} of its xacro output: joint 'world_to_trunk'")
    assert "is floating: it is drawn fixed at its origin" in warning
    assert robot.link_names[:2] == ("world", "trunk") and len(robot.joint_names) == 12
    model = pin.buildModelFromXML(urdf, mimic=True)
    assert model.joints[model.getJointId("world_to_trunk")].shortname() == "JointModelFreeFlyer"
    data = model.createData()
    rng = np.random.default_rng(1)
    chain = robot.chain
    for _ in range(CONFIGS):
        q = rng.uniform(chain.limits[:, 0], chain.limits[:, 1])
        poses, ok = chain.link_poses(q)
        q_pin = pin.neutral(model)  # the free flyer at rest: where linkview fixes it
        for name, value in zip(chain.joint_names, q, strict=True):
            q_pin[model.joints[model.getJointId(name)].idx_q] = value
        pin.framesForwardKinematics(model, data, q_pin)
        for k, name in enumerate(chain.link_names):
            theirs = data.oMf[model.getFrameId(name, pin.BODY)]
            assert np.abs(poses[k][:3, 3] - theirs.translation).max() <= TOL_M
            assert rotation_angle(poses[k][:3, :3], theirs.rotation) <= TOL_RAD
    trunk = chain.link_poses(np.zeros(chain.n_joints))[0][1]
    np.testing.assert_allclose(trunk[:3, 3], [0.2, 0.1, 0.35], atol=1e-12)
