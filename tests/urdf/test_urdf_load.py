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
    StandInGeometry,
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
            {"shoulder_type": "ball"},
            r"line 6: joint 'shoulder' has type 'ball'; supported types are revolute, "
            "continuous, prismatic, fixed, floating, planar",
        ),
        ({"limit": ""}, r"line 6: joint 'shoulder' .revolute. needs limits"),
        ({"mimic": "<mimic/>"}, r"line 15: joint 'wrist': <mimic> without a joint"),
        (
            {"origin": "0 zero 0.3"},
            r"line 13: joint 'wrist': <origin xyz> must be 3 number\(s\), got '0 zero 0.3'",
        ),
        (
            {"limit": '<limit lower="-1" upper="one"/>'},
            r"line 9: joint 'shoulder': <limit upper> must be 1 number\(s\), got 'one'",
        ),
    ],
)
def test_joint_errors_name_the_joint_and_its_line(
    tmp_path: Path, fields: dict[str, str], message: str
) -> None:
    path = write(tmp_path, **fields)
    with pytest.raises(UrdfError, match=message) as caught:
        load_urdf(path)
    assert str(caught.value).startswith(f"{path}, line ")


@pytest.mark.parametrize("kind", ["floating", "planar"])
def test_floating_and_planar_joints_are_fixed_at_their_origin_with_a_warning(
    tmp_path: Path, kind: str
) -> None:
    robot = load_urdf(write(tmp_path, shoulder_type=kind, origin="0.1 0.2 0.3"))
    (warning,) = robot.warnings
    assert warning.startswith(f"{tmp_path / 'urdf' / 'robot.urdf'}, line 6: ")
    assert f"joint 'shoulder' is {kind}: it is drawn fixed at its origin" in warning
    assert robot.joint_names == ("wrist",)
    poses, ok = robot.chain.link_poses(np.array([0.0]))
    assert ok
    np.testing.assert_allclose(poses[robot.link_names.index("hand")][:3, 3], [0.1, 0.2, 0.3])


def test_missing_and_unusable_meshes_are_warnings_and_stand_ins(tmp_path: Path) -> None:
    cases = {
        "package://nowhere/meshes/a.stl": "mesh 'package://nowhere/meshes/a.stl': package "
        "'nowhere' not found: it is not among the cell's packages (given: mesh_description)",
        "package://mesh_description/meshes/gone.stl": "mesh file "
        f"{MESH_DESCRIPTION / 'meshes' / 'gone.stl'} not found",
        "meshes/b.stl": f"mesh file {tmp_path / 'urdf' / 'meshes' / 'b.stl'} not found",
        "meshes/b.wrl": "mesh 'meshes/b.wrl' has an unsupported format",
        "https://example.com/b.stl": "only package://, file:// and file paths are supported",
    }
    for uri, message in cases.items():
        path = write(tmp_path, visual(f'<mesh filename="{uri}"/>'))
        robot = load_urdf(path, PACKAGES)
        (warning,) = robot.warnings
        assert warning.startswith(f"{path}, line 3: link 'base': "), warning
        assert message in warning and warning.endswith("; drawn as a stand-in"), warning
        (stand_in,) = robot.visuals["base"]
        # The stand-in reaches to where the link's child joint is (base -> arm is at 0).
        assert stand_in.geometry == StandInGeometry(())
    assert load_urdf(write(tmp_path, visual("<box size='0.1 0.1 0.1'/>"))).warnings == ()


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
    undeclared = tmp_path / "undeclared.urdf"
    undeclared.write_text('<robot name="a">\n<link name="a"/>\n<lnk name="b"></link>\n</robot>')
    with pytest.raises(UrdfError, match=r"undeclared.urdf: malformed XML, line 3: .*lnk"):
        load_urdf(undeclared)
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
        ("<box size='1 1 1'/><sphere radius='1'/>", "box, sphere"),
        ("<cone/>", "cone"),
    ):
        shapeless = write(tmp_path, visual(geometry))
        with pytest.raises(
            UrdfError, match=rf"line 3: a <visual> needs a <geometry> .*found: {found}"
        ):
            load_urdf(shapeless)
    with pytest.raises(UrdfError, match=r"line 3: link 'base': <sphere> without radius"):
        load_urdf(write(tmp_path, visual("<sphere/>")))
    with pytest.raises(UrdfError, match=r"line 3: <mesh> without a filename"):
        load_urdf(write(tmp_path, visual("<mesh/>")))
    two_roots = tmp_path / "two_roots.urdf"
    two_roots.write_text('<robot name="a"><link name="a"/><link name="b"/></robot>')
    with pytest.raises(UrdfError, match="single root link; roots found: a, b"):
        load_urdf(two_roots)
    stray = write(tmp_path).read_text().replace('<child link="hand"/>', '<child link="palm"/>')
    (tmp_path / "stray.urdf").write_text(stray)
    with pytest.raises(
        UrdfError, match=r"stray.urdf, line 11: joint 'wrist': its child link 'palm' is not"
    ):
        load_urdf(tmp_path / "stray.urdf")
