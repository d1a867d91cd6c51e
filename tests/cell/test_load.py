"""Cell files: every mistake is named by file, key path and reason; good files load as SI."""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

import numpy as np
import pytest

from server.cell import CellError, load_cell
from tests.test_cli import run_server

ROOT = Path(__file__).resolve().parents[2]
URDF_DIR = ROOT / "cells" / "examples" / "arm6" / "arm6_description"

SOURCE = '[[source]]\nname = "line1"\n'
TYPE12 = """
[[robot]]
name = "kin"
source = "line1"
kinematics = { type = "type12" }
joints = [ { node = "a" }, { node = "b" } ]
"""


def write(tmp_path: Path, text: str, name: str = "cell.toml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def problems(path: Path, env: dict[str, str] | None = None) -> list[str]:
    with pytest.raises(CellError) as caught:
        load_cell(path, env=env or {}, cache_dir=path.parent / "cache")
    lines = str(caught.value).splitlines()
    assert all(line.startswith(f"{path}: ") for line in lines), lines
    return [line[len(f"{path}: ") :] for line in lines]


def test_an_unknown_key_is_named(tmp_path: Path) -> None:
    path = write(
        tmp_path, SOURCE + TYPE12.replace('source = "line1"', 'source = "line1"\ncolor = 1')
    )
    assert problems(path) == ['robot[0] "kin".color: unknown key']


def test_a_wrong_unit_is_named_with_the_units_allowed(tmp_path: Path) -> None:
    path = write(
        tmp_path, SOURCE + TYPE12.replace('{ node = "b" }', '{ node = "b", unit = "grad" }')
    )
    assert problems(path) == [
        "robot[0] \"kin\".joints[1].unit: must be 'deg', 'rad', 'mm' or 'm', not 'grad' "
        "(did you mean 'rad'?)"
    ]


def test_a_linear_unit_on_a_rotary_joint_is_refused(tmp_path: Path) -> None:
    path = write(tmp_path, SOURCE + TYPE12.replace('{ node = "b" }', '{ node = "b", unit = "mm" }'))
    assert problems(path) == [
        "robot[0] \"kin\".joints[1].unit: joint 'a1' is rotary: unit must be deg or rad, not 'mm'"
    ]


def test_a_joint_count_that_does_not_match_the_kinematics(tmp_path: Path) -> None:
    path = write(tmp_path, SOURCE + TYPE12.replace(', { node = "b" }', ""))
    assert problems(path) == [
        'robot[0] "kin".joints: the type12 kinematics has 2 joints (a0, a1); 1 given'
    ]


def test_an_unknown_kinematics_type(tmp_path: Path) -> None:
    path = write(tmp_path, SOURCE + TYPE12.replace("type12", "scara"))
    assert problems(path) == [
        "robot[0] \"kin\".kinematics.type: must be one of type12, dh, axis_group, urdf, not 'scara'"
    ]


def test_a_missing_urdf(tmp_path: Path) -> None:
    robot = TYPE12.replace('{ type = "type12" }', '{ type = "urdf", file = "nope.urdf" }')
    (message,) = problems(write(tmp_path, SOURCE + robot))
    assert message.startswith('robot[0] "kin".kinematics.file: ') and "nope.urdf" in message
    assert "not found" in message or "no such file" in message.lower()


def test_a_malformed_urdf(tmp_path: Path) -> None:
    (tmp_path / "bad.urdf").write_text("<robot name='x'><link name='a'></robot>")
    robot = TYPE12.replace('{ type = "type12" }', '{ type = "urdf", file = "bad.urdf" }')
    (message,) = problems(write(tmp_path, SOURCE + robot))
    assert message.startswith('robot[0] "kin".kinematics.file: ') and "bad.urdf" in message


def test_a_missing_mesh_of_a_urdf_is_a_warning_from_check(tmp_path: Path) -> None:
    urdf = (URDF_DIR / "urdf" / "arm6.urdf").read_text()
    (tmp_path / "arm.urdf").write_text(urdf.replace("meshes/base.stl", "meshes/gone.stl"))
    nodes = ", ".join(f'{{ node = "n{i}" }}' for i in range(6))
    robot = f"""
    [[robot]]
    name = "arm"
    source = "line1"
    kinematics.type = "urdf"
    kinematics.file = "arm.urdf"
    kinematics.packages = {{ arm6_description = "{URDF_DIR}" }}
    joints = [{nodes}]
    """
    path = write(tmp_path, SOURCE + textwrap.dedent(robot))
    (arm,) = load_cell(path, env={}, cache_dir=tmp_path / "cache").robots
    (warning,) = arm.warnings
    assert "link 'base_link'" in warning and "gone.stl not found" in warning, warning
    assert all(mesh is not None for mesh in arm.meshes[:-1])  # the base: a stand-in
    assert arm.info().warnings == [warning]
    checked = run_server("check", str(path), env={"LINKVIEW_CACHE_DIR": str(tmp_path / "c")})
    assert checked.returncode == 0, checked.stderr
    assert checked.stdout.splitlines() == [
        f"{path}: arm: urdf, 6 joints, source line1, 7 meshes",
        f"{path}: arm: warning: {warning}",
    ]


def test_a_xacro_file_with_args_loads_and_its_errors_name_file_and_line(tmp_path: Path) -> None:
    (tmp_path / "arm.urdf.xacro").write_text(
        '<robot name="a" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        '  <xacro:arg name="lift" default="0.5"/>\n'
        '  <link name="base"/><link name="top"/>\n'
        '  <joint name="slide" type="prismatic"><parent link="base"/><child link="top"/>\n'
        '    <axis xyz="0 0 1"/><limit lower="0" upper="$(arg lift)"/></joint>\n'
        "</robot>\n"
    )
    robot = """
    [[robot]]
    name = "lifter"
    source = "line1"
    kinematics = { type = "urdf", file = "arm.urdf.xacro", args = { lift = "0.25" } }
    joints = [ { node = "z", unit = "mm" } ]
    """
    path = write(tmp_path, SOURCE + textwrap.dedent(robot))
    (lifter,) = load_cell(path, env={}, cache_dir=tmp_path / "cache").robots
    assert lifter.joints[0].limits == (0.0, 0.25)
    broken = (tmp_path / "arm.urdf.xacro").read_text().replace("</joint>", "</jiont>")
    (tmp_path / "arm.urdf.xacro").write_text(broken)
    (message,) = problems(path)
    assert message.startswith(
        f'robot[0] "lifter".kinematics.file: {tmp_path / "arm.urdf.xacro"}: malformed XML: '
        "mismatched tag: line 5"
    ), message


def test_a_missing_mesh_in_a_mesh_dir(tmp_path: Path) -> None:
    (tmp_path / "meshes").mkdir()
    for link in ("L1", "L5", "L4"):  # L2 is missing
        (tmp_path / "meshes" / f"{link}.glb").write_bytes(b"glTF")
    path = write(tmp_path, SOURCE + TYPE12 + 'mesh_dir = "meshes"\n')
    (message,) = problems(path)
    assert message.startswith('robot[0] "kin".mesh_dir: missing mesh for link L2: expected ')


def test_an_unknown_source(tmp_path: Path) -> None:
    path = write(tmp_path, SOURCE + TYPE12.replace('source = "line1"', 'source = "line9"'))
    assert problems(path) == ["robot[0] \"kin\".source: no source named 'line9' (sources: line1)"]


def test_duplicate_names(tmp_path: Path) -> None:
    path = write(tmp_path, SOURCE + SOURCE + TYPE12 + TYPE12)
    assert problems(path) == [
        "source[1] \"line1\".name: duplicate name 'line1' (also source[0])",
        "robot[1] \"kin\".name: duplicate name 'kin' (also robot[0])",
    ]


def test_a_password_variable_that_is_not_set(tmp_path: Path) -> None:
    source = '[[source]]\nname = "line1"\nurl = "https://192.0.2.1"\npassword_env = "LINE1_PW"\n'
    path = write(tmp_path, source + TYPE12)
    assert problems(path) == [
        'source[0] "line1".password_env: environment variable LINE1_PW is not set'
    ]
    cell = load_cell(path, env={"LINE1_PW": "pw"}, cache_dir=tmp_path)
    assert cell.sources[0].password == "pw" and "pw" not in repr(cell.sources[0])


def test_every_problem_is_reported_at_once(tmp_path: Path) -> None:
    # Four different mistakes: one of a source, one of a schema key, one found by checking
    # the joints against the kinematics, one of a robot that the schema refuses outright.
    cell = """
    [[source]]
    name = "line1"
    url = "https://192.0.2.1"
    password_env = "PW"

    [[robot]]
    name = "kin"
    source = "line1"
    kinematics = { type = "DH", d = [0.0], a = [100.0], alpha_deg = [0.0] }
    joints = [ { node = "a" } ]

    [[robot]]
    name = "arm"
    source = "line1"
    kinematics = { type = "type12" }
    joints = [ { node = "a" }, { node = "b" }, { node = "c" }, { node = "d", unit = "degree" } ]
    """
    assert problems(write(tmp_path, cell)) == [
        'source[0] "line1".password_env: environment variable PW is not set',
        'robot[0] "kin".kinematics.type: must be one of type12, dh, axis_group, urdf, '
        "not 'DH' (did you mean 'dh'?)",
        "robot[1] \"arm\".joints[3].unit: must be 'deg', 'rad', 'mm' or 'm', "
        "not 'degree' (did you mean 'deg'?)",
        'robot[1] "arm".joints: the type12 kinematics has 2 joints (a0, a1); 4 given',
    ]


def test_a_key_the_schema_refused_is_not_reported_twice(tmp_path: Path) -> None:
    # "metre" is refused; the default (deg) stands in for the other checks, which must not
    # then add that a linear joint needs mm or m.
    robot = """
    [[robot]]
    name = "slide"
    source = "line1"
    kinematics = { type = "axis_group", axes = [ { name = "x", type = "linear" } ] }
    joints = [ { node = "x", unit = "metre" } ]
    """
    assert problems(write(tmp_path, SOURCE + robot)) == [
        "robot[0] \"slide\".joints[0].unit: must be 'deg', 'rad', 'mm' or 'm', not 'metre'"
    ]


def test_one_of_a_thing_is_singular(tmp_path: Path) -> None:
    robot = """
    [[robot]]
    name = "one"
    source = "line1"
    kinematics = { type = "dh", d = [0.0], a = [100.0], alpha_deg = [0.0] }
    joints = [ { node = "a" }, { node = "b" } ]
    """
    (message,) = problems(write(tmp_path, SOURCE + robot))
    assert message.startswith('robot[0] "one".joints: the dh kinematics has 1 joint (')
    fixed = write(tmp_path, SOURCE + robot.replace(', { node = "b" }', ""), "fixed.toml")
    result = run_server("check", str(fixed))
    assert result.stdout == f"{fixed}: one: dh, 1 joint, source line1, no meshes\n"


def test_toml_syntax_errors_say_where(tmp_path: Path) -> None:
    (message,) = problems(write(tmp_path, SOURCE + "[[robot]\n"))
    assert message.startswith("(file): not valid TOML") and "line 3" in message


def test_a_joint_value_becomes_si_by_scale_offset_and_unit(tmp_path: Path) -> None:
    robot = TYPE12.replace(
        '{ node = "a" }', '{ node = "a", unit = "deg", scale = 0.001, offset = 10.0 }'
    ).replace('{ node = "b" }', '{ node = "b", unit = "rad", scale = -2.0 }')
    cell = load_cell(write(tmp_path, SOURCE + robot), env={}, cache_dir=tmp_path)
    (kin,) = cell.robots
    values = np.array([5000.0, 0.25])
    q = kin.to_si(values)
    np.testing.assert_allclose(q, [np.radians(5000.0 * 0.001 + 10.0), -0.5], rtol=1e-15)
    np.testing.assert_allclose(kin.from_si(q), values, rtol=1e-12)


def test_urdf_joints_may_be_named_in_any_order(tmp_path: Path) -> None:
    names = ["wrist_3_joint", "shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
             "wrist_1_joint", "wrist_2_joint"]  # fmt: skip
    joints = ", ".join(f'{{ node = "n_{n}", joint = "{n}" }}' for n in names)
    robot = f"""
    [[robot]]
    name = "arm"
    source = "line1"
    kinematics.type = "urdf"
    kinematics.file = "{URDF_DIR}/urdf/arm6.urdf"
    kinematics.packages = {{ arm6_description = "{URDF_DIR}" }}
    joints = [{joints}]
    """
    cell = load_cell(write(tmp_path, SOURCE + textwrap.dedent(robot)), env={}, cache_dir=tmp_path)
    (arm,) = cell.robots
    assert [j.name for j in arm.joints][0] == "shoulder_pan_joint"
    assert arm.joints[0].node == "n_shoulder_pan_joint" and arm.joints[5].node == "n_wrist_3_joint"
    wrong = textwrap.dedent(robot).replace('joint = "elbow_joint"', 'joint = "knee_joint"')
    (message,) = problems(write(tmp_path, SOURCE + wrong, "wrong.toml"))
    assert message.startswith("robot[0] \"arm\".joints[3].joint: no movable joint 'knee_joint'")


def test_check_prints_one_line_per_robot_and_exits_0(tmp_path: Path) -> None:
    files = ("cells/demo.toml", "cells/examples/two_controllers.toml")
    result = run_server("check", *files, env={"LINKVIEW_CACHE_DIR": str(tmp_path)})
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == [
        "cells/demo.toml: kin12: type12, 2 joints, source demo, 4 meshes",
        "cells/demo.toml: iiwa7: dh, 7 joints, source demo, 8 meshes",
        "cells/demo.toml: positioner: axis_group, 2 joints, source demo, 3 meshes",
        "cells/examples/two_controllers.toml: arm6: urdf, 6 joints, source line1, 7 meshes",
        "cells/examples/two_controllers.toml: picker: type12, 2 joints, source line2, 4 meshes",
    ]


def test_check_and_the_server_refuse_a_bad_cell_with_the_same_message(tmp_path: Path) -> None:
    path = write(tmp_path, SOURCE + TYPE12.replace('source = "line1"', 'source = "nope"'))
    checked = run_server("check", str(path))
    started = run_server("--cell", str(path), "--port", "0")
    expected = f"{path}: robot[0] \"kin\".source: no source named 'nope' (sources: line1)"
    assert checked.returncode == 1 and checked.stderr.strip() == expected
    assert started.returncode == 2 and expected in started.stderr
    assert "Traceback" not in checked.stderr + started.stderr


def test_docs_describe_every_key_and_their_example_is_valid() -> None:
    import tomllib

    from server.cell import schema

    doc = (ROOT / "docs" / "cell.md").read_text()
    example = doc.split("```toml\n", 1)[1].split("```", 1)[0]
    schema.Cell.model_validate(tomllib.loads(example))
    models = (schema.CtrlxSource, schema.RtdeSource, schema.MqttSource, schema.OpcuaSource)
    models += (schema.Robot, schema.Joint, schema.Type12, schema.DH)
    models += (schema.Axis, schema.AxisGroup, schema.Urdf, schema.Pose)
    prose = re.sub(r"```.*?```", "", doc, flags=re.S)
    named = {word for span in re.findall(r"`([^`]+)`", prose) for word in re.findall(r"\w+", span)}
    for model in models:
        keys = {field.alias or name for name, field in model.model_fields.items()}
        missing = keys - named
        assert not missing, f"docs/cell.md does not describe {model.__name__}.{missing}"


def test_an_empty_ca_file_is_named(tmp_path: Path) -> None:
    (tmp_path / "line1.pem").write_bytes(b"")
    path = write(tmp_path, SOURCE + 'ca = "line1.pem"\n' + TYPE12)
    assert problems(path) == [
        f'source[0] "line1".ca: CA file {tmp_path / "line1.pem"} is empty: '
        "it holds no PEM certificate"
    ]


def test_setpoint_nodes_are_mapped_as_their_joints_and_given_for_all_or_none(
    tmp_path: Path,
) -> None:
    robot = TYPE12.replace(
        '{ node = "a" }', '{ node = "a", scale = 0.5, setpoint = "/a/ipo/" }'
    ).replace('{ node = "b" }', '{ node = "b", setpoint = "b/ipo" }')
    (kin,) = load_cell(write(tmp_path, SOURCE + robot), env={}, cache_dir=tmp_path).robots
    assert kin.setpoint_nodes == ("a/ipo", "b/ipo")
    assert kin.followed == ("a", "b", "a/ipo", "b/ipo")
    info = kin.info().joints[0]
    assert (info.node, info.setpoint, info.scale, info.source_unit) == ("a", "a/ipo", 0.5, "deg")
    (plain,) = load_cell(
        write(tmp_path, SOURCE + TYPE12, "plain.toml"), env={}, cache_dir=tmp_path
    ).robots
    assert plain.setpoint_nodes == () and plain.followed == ("a", "b")
    half = TYPE12.replace('{ node = "b" }', '{ node = "b", setpoint = "b/ipo" }')
    assert problems(write(tmp_path, SOURCE + half, "half.toml")) == [
        'robot[0] "kin".joints[0].setpoint: give every joint a setpoint node, or none'
    ]
    empty = TYPE12.replace('{ node = "b" }', '{ node = "b", setpoint = "" }')
    (message,) = problems(write(tmp_path, SOURCE + empty, "empty.toml"))
    assert message.startswith('robot[0] "kin".joints[1].setpoint:')
