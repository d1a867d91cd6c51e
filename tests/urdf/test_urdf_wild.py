"""URDF as vendors write it: extension blocks, several visuals, capsules, package search, stand-ins.

Each test writes a small description that has one feature of real robot
descriptions, and checks what linkview makes of it.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh

from server.urdf import (
    BoxGeometry,
    CapsuleGeometry,
    MeshGeometry,
    SphereGeometry,
    StandInGeometry,
    UrdfError,
    link_meshes,
    load_urdf,
)

FIXTURES = Path(__file__).parent / "fixtures"
TOOL_STL = FIXTURES / "mesh_description" / "meshes" / "tool.stl"  # a 0.04 m cube, centred
TOL = 1e-6

# The shape of ROS-Industrial's UR5 description: <transmission> blocks name the
# joints (without parent or child) before the joints themselves are defined.
EXTENDED = """<?xml version="1.0"?>
<robot name="ur_like" xmlns:drake="http://drake.mit.edu">
  <transmission name="shoulder_trans">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="shoulder"><hardwareInterface>PositionJointInterface</hardwareInterface></joint>
    <actuator name="shoulder_motor"><mechanicalReduction>1</mechanicalReduction></actuator>
  </transmission>
  <gazebo reference="base"><material>Gazebo/Orange</material><joint name="phantom"/></gazebo>
  <ros2_control name="hw" type="system">
    <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
    <joint name="shoulder"><command_interface name="position"/></joint>
  </ros2_control>
  <vendor_tool_settings><joint name="other" type="revolute"/></vendor_tool_settings>
  <link name="base">
    <inertial><mass value="4"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <collision><geometry><mesh filename="package://missing/collision.stl"/></geometry></collision>
  </link>
  <link name="arm"/>
  <joint name="shoulder" type="continuous">
    <parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/>
    <limit effort="1" velocity="1" drake:acceleration="8"/>
  </joint>
</robot>
"""


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def glb(path: Path) -> trimesh.Scene:
    scene = trimesh.load(path, force="scene")
    assert isinstance(scene, trimesh.Scene)
    return scene


def test_extension_blocks_and_their_joints_are_ignored(tmp_path: Path) -> None:
    robot = load_urdf(write(tmp_path / "ur.urdf", EXTENDED))
    assert robot.joint_names == ("shoulder",)
    assert robot.link_names == ("base", "arm")
    assert robot.warnings == ()
    assert robot.visuals == {"base": (), "arm": ()}  # collisions are not drawn
    assert link_meshes(robot, tmp_path / "cache").files == {}  # no visual, no mesh


def test_a_default_namespace_is_read_like_none(tmp_path: Path) -> None:
    text = EXTENDED.replace('<robot name="ur_like"', '<robot name="ur_like" xmlns="urn:any"')
    assert load_urdf(write(tmp_path / "ns.urdf", text)).joint_names == ("shoulder",)


SEVERAL = f"""<?xml version="1.0"?>
<robot name="several">
  <material name="orange"><color rgba="1 0.5 0 1"/></material>
  <link name="base">
    <visual>
      <origin xyz="0 0 0.05"/>
      <geometry><box size="0.2 0.1 0.1"/></geometry>
      <material name="inline_grey"><color rgba="0.5 0.5 0.5 1"/></material>
    </visual>
    <visual>
      <origin xyz="0.3 0 0" rpy="0 0 1.5707963267948966"/>
      <geometry><mesh filename="file://{TOOL_STL}" scale="2 1 1"/></geometry>
      <material name="orange"/>
    </visual>
    <visual>
      <origin xyz="-0.3 0 0"/>
      <geometry><capsule radius="0.05" length="0.2"/><material name="orange"/></geometry>
    </visual>
    <visual>
      <geometry><sphere radius="0.0"/></geometry>
    </visual>
  </link>
</robot>
"""


def test_several_visuals_each_with_origin_geometry_scale_and_colour(tmp_path: Path) -> None:
    robot = load_urdf(write(tmp_path / "several.urdf", SEVERAL))
    box, mesh, capsule = robot.visuals["base"]  # the sphere of radius 0 draws nothing
    assert box.geometry == BoxGeometry((0.2, 0.1, 0.1)) and box.rgba == (0.5, 0.5, 0.5, 1.0)
    assert isinstance(mesh.geometry, MeshGeometry) and mesh.geometry.scale == (2.0, 1.0, 1.0)
    assert mesh.rgba == (1.0, 0.5, 0.0, 1.0)  # named at the top level
    # A <material> misplaced inside <geometry>, as some exporters write it, still colours.
    assert capsule.geometry == CapsuleGeometry(0.05, 0.2) and capsule.rgba == mesh.rgba
    np.testing.assert_allclose(capsule.origin[:3, 3], [-0.3, 0.0, 0.0])

    (path,) = link_meshes(robot, tmp_path / "cache").files.values()
    parts = sorted(glb(path).geometry.values(), key=lambda g: g.bounds[0, 0])
    # Capsule: 0.2 between its spheres' centres along z, 0.05 round.
    np.testing.assert_allclose(
        parts[0].bounds, [[-0.35, -0.05, -0.15], [-0.25, 0.05, 0.15]], atol=1e-3
    )
    np.testing.assert_allclose(parts[1].bounds, [[-0.1, -0.05, 0.0], [0.1, 0.05, 0.1]], atol=TOL)
    # The cube, scaled 2x along its own x, then turned a quarter about z: 0.04 x 0.08.
    np.testing.assert_allclose(
        parts[2].bounds, [[0.28, -0.04, -0.02], [0.32, 0.04, 0.02]], atol=TOL
    )


def test_a_glb_mesh_keeps_its_own_material(tmp_path: Path) -> None:
    red = trimesh.creation.box((0.1, 0.1, 0.1))
    red.visual = trimesh.visual.TextureVisuals(
        material=trimesh.visual.material.PBRMaterial(baseColorFactor=[230, 20, 20, 255])
    )
    (tmp_path / "red.glb").write_bytes(trimesh.Scene(red).export(file_type="glb"))
    urdf = write(
        tmp_path / "glb.urdf",
        '<robot name="g"><link name="a"><visual><geometry><mesh filename="red.glb"/>'
        '</geometry><material name="b"><color rgba="0 0 1 1"/></material></visual></link></robot>',
    )
    (path,) = link_meshes(load_urdf(urdf), tmp_path / "cache").files.values()
    (geometry,) = glb(path).geometry.values()
    r, g, b, _ = geometry.visual.material.baseColorFactor
    assert r > 200 and g < 40 and b < 40


def mesh_user(package: str) -> str:
    return (
        '<robot name="m"><link name="a"><visual><geometry>'
        f'<mesh filename="package://{package}/meshes/tool.stl"/>'
        "</geometry></visual></link></robot>"
    )


def put_mesh(folder: Path) -> Path:
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    shutil.copy(TOOL_STL, folder / "meshes" / "tool.stl")
    return folder / "meshes" / "tool.stl"


def mesh_path(urdf: Path, packages: dict[str, Path] | None = None) -> Path:
    robot = load_urdf(urdf, packages)
    assert robot.warnings == (), robot.warnings
    (visual,) = robot.visuals["a"]
    assert isinstance(visual.geometry, MeshGeometry)
    return visual.geometry.path


def test_packages_are_found_by_walking_up_from_the_description(tmp_path: Path) -> None:
    # The description package itself, by its folder's name.
    stl = put_mesh(tmp_path / "src" / "arm_description")
    urdf = write(
        tmp_path / "src" / "arm_description" / "urdf" / "arm.urdf", mesh_user("arm_description")
    )
    assert mesh_path(urdf) == stl
    # By the name in its package.xml, whatever its folder is called (a git clone's name).
    stl = put_mesh(tmp_path / "clone-of-description")
    write(
        tmp_path / "clone-of-description" / "package.xml",
        "<package><name>real_name</name></package>",
    )
    urdf = write(tmp_path / "clone-of-description" / "urdf" / "a.urdf", mesh_user("real_name"))
    assert mesh_path(urdf) == stl
    # A sibling package of a workspace: by folder name, or by its package.xml.
    stl = put_mesh(tmp_path / "src" / "arm_meshes")
    urdf = write(tmp_path / "src" / "arm_description" / "urdf" / "b.urdf", mesh_user("arm_meshes"))
    assert mesh_path(urdf) == stl
    stl = put_mesh(tmp_path / "src" / "gripper-v2")
    write(
        tmp_path / "src" / "gripper-v2" / "package.xml", "<package><name>gripper</name></package>"
    )
    urdf = write(tmp_path / "src" / "arm_description" / "urdf" / "c.urdf", mesh_user("gripper"))
    assert mesh_path(urdf) == stl
    # The cell's packages come first.
    elsewhere = put_mesh(tmp_path / "elsewhere")
    assert mesh_path(urdf, {"gripper": tmp_path / "elsewhere"}) == elsewhere


def test_an_empty_package_host_is_read_as_the_package_path(tmp_path: Path) -> None:
    # example-robot-data's Talos writes "package:///example-robot-data/robots/...".
    stl = put_mesh(tmp_path / "share" / "robot_data")
    urdf = write(
        tmp_path / "share" / "robot_data" / "urdf" / "r.urdf",
        mesh_user("robot_data").replace("package://", "package:///"),
    )
    assert mesh_path(urdf) == stl


MIMIC_OF_NOTHING = """<robot name="hand">
  <link name="palm"/><link name="f1"/><link name="f2"/>
  <joint name="q1" type="revolute">
    <parent link="palm"/><child link="f1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1"/>
  </joint>
  <joint name="q2" type="revolute">
    <parent link="f1"/><child link="f2"/><origin xyz="0.1 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1"/>
    <mimic joint="renamed_q1" multiplier="2"/>
  </joint>
</robot>
"""


def test_a_mimic_of_an_unknown_joint_is_a_joint_of_its_own_with_a_warning(
    tmp_path: Path,
) -> None:
    robot = load_urdf(write(tmp_path / "hand.urdf", MIMIC_OF_NOTHING))
    (warning,) = robot.warnings
    assert "hand.urdf, line 9: joint 'q2' mimics 'renamed_q1'" in warning, warning
    assert robot.joint_names == ("q1", "q2")  # q2 is followed, not derived from q1
    poses, ok = robot.chain.link_poses(np.array([0.0, 0.5]))
    assert ok.all()
    np.testing.assert_allclose(poses[2][:2, 0], [np.cos(0.5), np.sin(0.5)], atol=1e-12)


def test_a_nameless_robot_loads_but_one_without_links_is_refused(tmp_path: Path) -> None:
    nameless = load_urdf(write(tmp_path / "n.urdf", MIMIC_OF_NOTHING.replace(' name="hand"', "")))
    assert any("<robot> without a name" in w for w in nameless.warnings), nameless.warnings
    # ur_description's ur3.urdf in example-robot-data: an empty <robot>.
    empty = write(tmp_path / "e.urdf", '<?xml version="1.0"?>\n<robot xmlns:xacro="x">\n</robot>')
    with pytest.raises(UrdfError, match=r"e.urdf, line 2: <robot> holds no <link>"):
        load_urdf(empty)


STAND_IN = """<robot name="s">
  <link name="base">
    <visual>
      <geometry><mesh filename="{mesh}"/></geometry>
      <material name="r"><color rgba="1 0 0 1"/></material>
    </visual>
  </link>
  <link name="arm"/>
  <joint name="j" type="revolute">
    <parent link="base"/><child link="arm"/>
    <origin xyz="0.3 0 0.4"/>
    <limit lower="-1" upper="1"/>
  </joint>
</robot>
"""


def test_a_missing_mesh_is_a_stand_in_reaching_to_the_next_joint(tmp_path: Path) -> None:
    robot = load_urdf(write(tmp_path / "s.urdf", STAND_IN.format(mesh="gone.stl")))
    (warning,) = robot.warnings
    assert "link 'base': mesh file" in warning and "gone.stl not found" in warning
    (visual,) = robot.visuals["base"]
    assert visual.geometry == StandInGeometry(((0.3, 0.0, 0.4),)) and visual.rgba == (1, 0, 0, 1)
    meshes = link_meshes(robot, tmp_path / "cache")
    assert meshes.warnings == ()  # said once, by load_urdf
    bounds = glb(meshes.files["base"]).bounds
    assert bounds[1, 0] > 0.3 and bounds[1, 2] > 0.4 and bounds[0, 0] < -0.015


def test_an_unreadable_mesh_is_a_stand_in_and_a_warm_cache_still_says_so(tmp_path: Path) -> None:
    (tmp_path / "broken.dae").write_text("<COLLADA><library_geometries><geometry>")
    robot = load_urdf(write(tmp_path / "s.urdf", STAND_IN.format(mesh="broken.dae")))
    assert robot.warnings == ()  # the file is there; reading it is the converter's job
    first = link_meshes(robot, tmp_path / "cache")
    (warning,) = first.warnings
    assert warning.startswith("link 'base': mesh 'broken.dae'") and "cannot be read" in warning
    assert glb(first.files["base"]).bounds[1, 0] > 0.3  # the stand-in
    again = link_meshes(load_urdf(tmp_path / "s.urdf"), tmp_path / "cache")
    assert again.files == first.files and again.warnings == first.warnings
    notes = first.files["base"].with_suffix(".warnings.json")
    assert json.loads(notes.read_text()) == [warning]


@pytest.mark.parametrize("shape", ["<sphere radius='0.1'/>", "<box size='0 0 0'/>"])
def test_primitives_with_and_without_volume(tmp_path: Path, shape: str) -> None:
    urdf = write(
        tmp_path / "p.urdf",
        f'<robot name="p"><link name="a"><visual><geometry>{shape}</geometry></visual></link>'
        "</robot>",
    )
    visuals = load_urdf(urdf).visuals["a"]
    assert [type(v.geometry) for v in visuals] == ([SphereGeometry] if "0.1" in shape else [])


def test_mesh_materials_are_not_metals_unless_they_say_so(tmp_path: Path) -> None:
    # OBJ (MTL) colours have no metalness; glTF's default of 1 would draw them black.
    mesh = trimesh.creation.box((0.1, 0.1, 0.1))
    blue = trimesh.visual.material.SimpleMaterial(diffuse=[125, 173, 204, 255], glossiness=225)
    mesh.visual = trimesh.visual.TextureVisuals(material=blue)
    text, files = trimesh.exchange.obj.export_obj(mesh, return_texture=True, mtl_name="b.mtl")
    (tmp_path / "b.obj").write_text(text)
    (tmp_path / "b.mtl").write_bytes(files["b.mtl"])
    urdf = write(
        tmp_path / "obj.urdf",
        '<robot name="o"><link name="a"><visual><geometry><mesh filename="b.obj"/>'
        "</geometry></visual></link></robot>",
    )
    (path,) = link_meshes(load_urdf(urdf), tmp_path / "cache").files.values()
    (geometry,) = glb(path).geometry.values()
    material = geometry.visual.material
    assert material.metallicFactor == 0.0
    assert list(material.baseColorFactor[:3]) == [125, 173, 204]
