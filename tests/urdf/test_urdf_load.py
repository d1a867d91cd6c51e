"""load_urdf: what a robot carries (joints, limits, units, visuals, paths) and every error."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from server.urdf import (
    BoxGeometry,
    CylinderGeometry,
    MeshGeometry,
    SphereGeometry,
    UrdfError,
    load_urdf,
)

FIXTURES = Path(__file__).parent / "fixtures"
MESH_DESCRIPTION = FIXTURES / "mesh_description"
MESH_ARM = MESH_DESCRIPTION / "urdf" / "mesh_arm.urdf"
PACKAGES = {"mesh_description": MESH_DESCRIPTION}


def test_joints_limits_and_units() -> None:
    robot = load_urdf(FIXTURES / "lift_gripper.urdf")
    assert robot.name == "lift_gripper"
    assert robot.joint_names == ("lift", "shoulder", "elbow", "wrist_joint", "finger_left_joint")
    assert robot.joint_units == ("m", "rad", "rad", "rad", "m")
    np.testing.assert_array_equal(
        robot.limits, [[0.0, 0.6], [-math.inf, math.inf], [-2.6, 2.6], [-3, 3], [0, 0.04]]
    )
    assert robot.link_names[0] == "base" and len(robot.link_names) == 9
    assert robot.chain.tip == "finger_right"  # deepest, listed first
    assert load_urdf(FIXTURES / "lift_gripper.urdf", tip="palm").chain.tip == "palm"


def test_visuals_resolve_packages_relative_paths_and_colours() -> None:
    robot = load_urdf(MESH_ARM, PACKAGES)
    assert set(robot.visuals) == set(robot.link_names)
    assert robot.visuals["slider"] == ()
    (base,) = robot.visuals["base"]
    assert isinstance(base.geometry, MeshGeometry)
    assert base.geometry.path.resolve() == (MESH_DESCRIPTION / "meshes" / "base.stl").resolve()
    assert base.geometry.uri == "package://mesh_description/meshes/base.stl"
    assert base.rgba == (0.1, 0.3, 0.8, 1.0)
    # A material named but defined in another link's visual.
    assert robot.visuals["link1"][0].rgba == (0.1, 0.3, 0.8, 1.0)
    (link2,) = robot.visuals["link2"]
    assert link2.rgba is None and isinstance(link2.geometry, MeshGeometry)
    assert link2.geometry.scale == (1.0, 1.0, 0.5)
    np.testing.assert_allclose(link2.origin[:3, 3], [0.1, 0.0, 0.0])
    (tool,) = robot.visuals["tool"]
    assert isinstance(tool.geometry, MeshGeometry)  # "../meshes/tool.stl", next to the URDF
    assert tool.geometry.path.resolve() == (MESH_DESCRIPTION / "meshes" / "tool.stl").resolve()
    assert tool.geometry.scale == (2.0, 1.0, 1.0) and tool.rgba == (0.1, 0.7, 0.2, 0.5)


def test_primitives_and_top_level_materials() -> None:
    robot = load_urdf(FIXTURES / "serial6.urdf")
    (base,) = robot.visuals["base"]
    assert base.geometry == CylinderGeometry(0.1, 0.05) and base.rgba == (0.9, 0.45, 0.1, 1.0)
    (l1,) = robot.visuals["l1"]
    assert l1.geometry == BoxGeometry((0.1, 0.12, 0.2))
    np.testing.assert_allclose(l1.origin[:3, 3], [0, 0, 0.1])
    (l2,) = robot.visuals["l2"]
    assert l2.geometry == SphereGeometry(0.06) and l2.rgba is None


def test_file_uris_and_absolute_paths(tmp_path: Path) -> None:
    stl = (MESH_DESCRIPTION / "meshes" / "tool.stl").resolve()
    for uri in (f"file://{stl}", str(stl)):
        path = write(tmp_path, visual(f'<mesh filename="{uri}"/>'))
        (only,) = load_urdf(path).visuals["base"]
        assert isinstance(only.geometry, MeshGeometry) and only.geometry.path == stl


ARM = """<?xml version="1.0"?>
<robot name="bad">
  <link name="base">{visual}</link>
  <link name="arm"/>
  <link name="hand"/>
  <joint name="shoulder" type="{shoulder_type}">
    <parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/>
    {limit}
  </joint>
  <joint name="wrist" type="revolute">
    <parent link="arm"/><child link="hand"/>
    <origin xyz="{origin}" rpy="0 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
    {mimic}
  </joint>
</robot>
"""
LIMIT = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'


def visual(geometry: str) -> str:
    return f"<visual><geometry>{geometry}</geometry></visual>"


def write(tmp_path: Path, visual: str = "", **fields: str) -> Path:
    values = {"shoulder_type": "revolute", "limit": LIMIT, "origin": "0 0 0.3", "mimic": ""}
    values.update(fields)
    path = tmp_path / "urdf" / "robot.urdf"
    path.parent.mkdir(exist_ok=True)
    path.write_text(ARM.format(visual=visual, **values))
    return path


def test_a_good_file_from_the_template_loads(tmp_path: Path) -> None:
    robot = load_urdf(write(tmp_path))
    assert robot.joint_names == ("shoulder", "wrist")


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        (
            {"shoulder_type": "floating"},
            "joint 'shoulder' has type 'floating'; supported types are",
        ),
        ({"shoulder_type": "planar"}, "joint 'shoulder' has type 'planar'"),
        ({"limit": ""}, "joint 'shoulder' .revolute. needs limits"),
        ({"mimic": '<mimic joint="elbow"/>'}, "joint 'wrist' mimics 'elbow', which is not a joint"),
        ({"origin": "0 zero 0.3"}, "cannot read the robot description"),
    ],
)
def test_joint_errors_name_the_joint(tmp_path: Path, fields: dict[str, str], message: str) -> None:
    path = write(tmp_path, **fields)
    with pytest.raises(UrdfError, match=message) as caught:
        load_urdf(path)
    assert str(caught.value).startswith(str(path))


def test_mesh_errors_name_the_link_and_the_path(tmp_path: Path) -> None:
    unknown = write(tmp_path, visual('<mesh filename="package://nowhere/meshes/a.stl"/>'))
    with pytest.raises(
        UrdfError,
        match=r"link 'base': mesh 'package://nowhere/meshes/a.stl' is "
        r"in package 'nowhere', which is not among the packages given "
        r"\(given: mesh_description\)",
    ):
        load_urdf(unknown, PACKAGES)
    missing = write(
        tmp_path, visual('<mesh filename="package://mesh_description/meshes/gone.stl"/>')
    )
    gone = MESH_DESCRIPTION / "meshes" / "gone.stl"
    with pytest.raises(UrdfError, match=f"link 'base': mesh file {gone} not found"):
        load_urdf(missing, PACKAGES)
    relative = write(tmp_path, visual('<mesh filename="meshes/b.stl"/>'))
    with pytest.raises(
        UrdfError, match=f"mesh file {tmp_path / 'urdf' / 'meshes' / 'b.stl'} not found"
    ):
        load_urdf(relative)
    ply = write(tmp_path, visual('<mesh filename="meshes/b.ply"/>'))
    with pytest.raises(
        UrdfError, match="link 'base': mesh 'meshes/b.ply' has an unsupported format"
    ):
        load_urdf(ply)
    web = write(tmp_path, visual('<mesh filename="https://example.com/b.stl"/>'))
    with pytest.raises(UrdfError, match="only package://, file:// and file paths are supported"):
        load_urdf(web)


def test_file_and_xml_errors(tmp_path: Path) -> None:
    with pytest.raises(UrdfError, match=f"URDF file {tmp_path / 'none.urdf'} not found"):
        load_urdf(tmp_path / "none.urdf")
    broken = tmp_path / "broken.urdf"
    broken.write_text('<?xml version="1.0"?>\n<robot name="x">\n  <link name="a">\n</robot>\n')
    with pytest.raises(UrdfError, match=r"broken.urdf: malformed XML, line 4: .*link"):
        load_urdf(broken)
    other = tmp_path / "other.urdf"
    other.write_text("<sdf/>")
    with pytest.raises(UrdfError, match="the root element is <sdf>, not <robot>"):
        load_urdf(other)
    xacro = tmp_path / "arm.urdf.xacro"
    xacro.write_text(
        '<robot name="a" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:property name="l" value="1"/><link name="a"/></robot>'
    )
    with pytest.raises(UrdfError, match="is a xacro file: expand it"):
        load_urdf(xacro)
    nameless = tmp_path / "nameless.urdf"
    nameless.write_text('<robot name="a">\n<link name="a"/>\n<link/>\n</robot>')
    with pytest.raises(UrdfError, match=r"line 3: <link> without a name"):
        load_urdf(nameless)
    orphan = tmp_path / "orphan.urdf"
    orphan.write_text(
        '<robot name="a"><link name="a"/><link name="b"/>\n'
        '<joint name="j" type="fixed"><child link="b"/></joint></robot>'
    )
    with pytest.raises(UrdfError, match=r"line 2: joint 'j' has no <parent link=\"...\"/>"):
        load_urdf(orphan)
    for geometry, found in (
        ("", "nothing"),
        ("<box/><sphere/>", "box, sphere"),
        ("<cone/>", "cone"),
    ):
        shapeless = write(tmp_path, visual(geometry))
        with pytest.raises(
            UrdfError, match=rf"line 3: a <visual> needs a <geometry> .*found: {found}"
        ):
            load_urdf(shapeless)
    with pytest.raises(UrdfError, match=r"line 3: <mesh> without a filename"):
        load_urdf(write(tmp_path, visual("<mesh/>")))
    two_roots = tmp_path / "two_roots.urdf"
    two_roots.write_text('<robot name="a"><link name="a"/><link name="b"/></robot>')
    with pytest.raises(UrdfError, match="single root link; roots found: a, b"):
        load_urdf(two_roots)
