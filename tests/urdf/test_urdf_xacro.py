"""xacro files load as URDF: arguments, $(find) like package://, and errors that say where."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from server.urdf import MeshGeometry, UrdfError, load_urdf
from tests.urdf.real_xacro import real_xacro

TOOL_STL = Path(__file__).parent / "fixtures" / "mesh_description" / "meshes" / "tool.stl"

MACRO = """<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:macro name="arm" params="prefix length">
    <link name="${prefix}base">
      <visual><geometry><mesh filename="package://arm_description/meshes/tool.stl"/></geometry></visual>
    </link>
    <link name="${prefix}tool"/>
    <joint name="${prefix}joint_1" type="revolute">
      <parent link="${prefix}base"/><child link="${prefix}tool"/>
      <origin xyz="0 0 ${length}"/>
      <axis xyz="0 0 1"/>
      <limit lower="${-pi}" upper="${pi}" effort="1" velocity="1"/>
    </joint>
  </xacro:macro>
</robot>
"""

TOP = """<?xml version="1.0"?>
<robot name="arm" xmlns:xacro="http://wiki.ros.org/xacro">
  <xacro:arg name="prefix" default="left_"/>
  <xacro:arg name="length_mm" default="300"/>
  <xacro:include filename="$(find arm_description)/urdf/arm_macro.xacro"/>
  <xacro:arm prefix="$(arg prefix)" length="${$(arg length_mm) / 1000.0}"/>
  <transmission name="t"><joint name="$(arg prefix)joint_1"/></transmission>
</robot>
"""


def package(tmp_path: Path) -> Path:
    """An ``arm_description`` ROS package (a git clone named otherwise) with a xacro arm."""
    root = tmp_path / "ws" / "src" / "arm-description-main"
    (root / "urdf").mkdir(parents=True)
    (root / "meshes").mkdir()
    shutil.copy(TOOL_STL, root / "meshes" / "tool.stl")
    (root / "package.xml").write_text(
        '<?xml version="1.0"?>\n<package format="3"><name>arm_description</name></package>'
    )
    (root / "urdf" / "arm_macro.xacro").write_text(MACRO)
    (root / "urdf" / "arm.urdf.xacro").write_text(TOP)
    return root


def test_a_xacro_file_expands_with_its_arguments_and_finds_its_package(tmp_path: Path) -> None:
    root = package(tmp_path)
    robot = load_urdf(root / "urdf" / "arm.urdf.xacro")
    assert robot.name == "arm" and robot.joint_names == ("left_joint_1",)
    np.testing.assert_allclose(robot.limits, [[-np.pi, np.pi]])
    poses, _ = robot.chain.link_poses(np.zeros(1))
    np.testing.assert_allclose(poses[1][:3, 3], [0, 0, 0.3])
    (visual,) = robot.visuals["left_base"]
    assert isinstance(visual.geometry, MeshGeometry)
    assert visual.geometry.path == root / "meshes" / "tool.stl"

    robot = load_urdf(root / "urdf" / "arm.urdf.xacro", args={"prefix": "", "length_mm": "450"})
    assert robot.joint_names == ("joint_1",)
    poses, _ = robot.chain.link_poses(np.zeros(1))
    np.testing.assert_allclose(poses[1][:3, 3], [0, 0, 0.45])


def test_find_takes_the_cells_packages_first(tmp_path: Path) -> None:
    root = package(tmp_path)
    other = tmp_path / "other"
    shutil.copytree(root, other)
    (other / "urdf" / "arm_macro.xacro").write_text(
        MACRO.replace("${prefix}tool", "${prefix}flange")
    )
    robot = load_urdf(root / "urdf" / "arm.urdf.xacro", {"arm_description": other})
    assert robot.link_names == ("left_base", "left_flange")


def test_a_plain_urdf_with_substitutions_is_expanded(tmp_path: Path) -> None:
    # As pybullet's Husky: a .urdf that still holds $(optenv NAME default).
    urdf = tmp_path / "husky.urdf"
    urdf.write_text(
        '<robot name="h"><link name="a"/><link name="b"/><joint name="imu" type="fixed">'
        '<parent link="a"/><child link="b"/>'
        '<origin xyz="$(optenv LINKVIEW_TEST_UNSET_XYZ 0.19 0 0.149)"/></joint></robot>'
    )
    poses, _ = load_urdf(urdf).chain.link_poses(np.zeros(0))
    np.testing.assert_allclose(poses[1][:3, 3], [0.19, 0, 0.149])


def test_xacro_errors_name_the_file_xacro_was_reading(tmp_path: Path) -> None:
    root = package(tmp_path)
    macro = root / "urdf" / "arm_macro.xacro"
    top = root / "urdf" / "arm.urdf.xacro"
    macro.write_text(MACRO.replace("</xacro:macro>", "</xacro:macr>"))
    with pytest.raises(UrdfError, match=rf"^{macro}: malformed XML: mismatched tag: line 14"):
        load_urdf(top)
    macro.write_text(MACRO.replace("${length}", "${lenght}"))
    with pytest.raises(UrdfError, match=rf"^{top}: xacro: .*lenght"):
        load_urdf(top)
    top.write_text(TOP.replace('<xacro:arg name="length_mm" default="300"/>', ""))
    macro.write_text(MACRO)
    with pytest.raises(
        UrdfError, match=rf"^{top}: xacro: Undefined substitution argument length_mm"
    ):
        load_urdf(top)
    top.write_text(TOP.replace("$(find arm_description)", "$(find arm_support)"))
    with pytest.raises(
        UrdfError,
        match=rf"^{top}: xacro: \$\(find arm_support\): package 'arm_support' not found: it is "
        r"not among the cell's packages \(given: none\)",
    ):
        load_urdf(top)
    with pytest.raises(UrdfError, match="xacro file .*none.xacro not found"):
        load_urdf(tmp_path / "none.xacro")


def test_an_error_in_the_expanded_urdf_names_its_line(tmp_path: Path) -> None:
    top = tmp_path / "arm.xacro"
    top.write_text(
        '<robot name="a" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        '<xacro:arg name="xyz" default="0 0 1"/>\n<link name="a"/>\n<link name="b"/>\n'
        '<joint name="j" type="fixed"><parent link="a"/><child link="b"/>\n'
        '<origin xyz="$(arg xyz)"/></joint>\n</robot>\n'
    )
    poses, _ = load_urdf(top).chain.link_poses(np.zeros(0))
    np.testing.assert_allclose(poses[1][:3, 3], [0, 0, 1])
    # The line is the one the xacro command prints the <origin> on, arguments given.
    output = real_xacro(top, {"xyz": "0 1"}, {}).stdout.splitlines()
    line = next(i for i, text in enumerate(output, 1) if "<origin" in text)
    with pytest.raises(
        UrdfError,
        match=rf"^{top}, line {line} of its xacro output: joint 'j': <origin xyz> must be 3",
    ):
        load_urdf(top, args={"xyz": "0 1"})
