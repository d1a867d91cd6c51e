"""Cells with RTDE and MQTT sources: joint spellings, defaults, and every mistake named."""

from __future__ import annotations

from pathlib import Path

import pytest

from server.cell import load_cell
from server.cell.load import CellError

DH6 = (
    'kinematics = { type = "dh", d = [162.5, 0.0, 0.0, 133.3, 99.7, 99.6], '
    "a = [0.0, -425.0, -392.2, 0.0, 0.0, 0.0], alpha_deg = [90.0, 0.0, 0.0, 90.0, -90.0, 0.0] }"
)
TWO = 'kinematics = { type = "axis_group", axes = [{ name = "a" }, { name = "b", parent = "a" }] }'


def cell(tmp_path: Path, source: str, robot: str) -> Path:
    path = tmp_path / "cell.toml"
    path.write_text(
        f'[[source]]\nname = "s"\n{source}\n\n[[robot]]\nname = "r"\nsource = "s"\n{robot}\n'
    )
    return path


def problems(path: Path) -> list[tuple[str, str]]:
    with pytest.raises(CellError) as caught:
        load_cell(path, env={}, cache_dir=path.parent / "cache")
    return caught.value.problems


def test_a_ur_arm_without_joints_reads_actual_q_in_radians_with_target_q_setpoints(
    tmp_path: Path,
) -> None:
    loaded = load_cell(cell(tmp_path, 'type = "rtde"\nurl = "rtde://10.0.0.2"', DH6), env={})
    (robot,) = loaded.robots
    assert [j.node for j in robot.joints] == [f"actual_q[{i}]" for i in range(6)]
    assert [j.setpoint for j in robot.joints] == [f"target_q[{i}]" for i in range(6)]
    assert {j.source_unit for j in robot.joints} == {"rad"}
    assert loaded.sources[0].type == "rtde" and loaded.sources[0].url == "rtde://10.0.0.2"


def test_rtde_joints_by_field_index_register_or_node_are_one_key_each(tmp_path: Path) -> None:
    joints = 'joints = [{ field = "actual_q", index = 2 }, { register = 24, unit = "deg" }]'
    (robot,) = load_cell(cell(tmp_path, 'type = "rtde"', f"{TWO}\n{joints}"), env={}).robots
    assert [j.node for j in robot.joints] == ["actual_q[2]", "output_double_register_24"]
    assert [j.source_unit for j in robot.joints] == ["rad", "deg"]


@pytest.mark.parametrize(
    ("joints", "key", "reason"),
    [
        ('[{ node = "actual_q[7]" }, { register = 1 }]', "joints[0].node", "index 0 to 5"),
        ('[{ node = "actual_q" }, { register = 1 }]', "joints[0].node", "has 6 values"),
        ('[{ node = "x", register = 2 }, { register = 1 }]', "joints[0]", "not node and register"),
        ("[{ index = 2 }, { register = 1 }]", "joints[0]", "not none of them"),
        ('[{ register = 1 }, { register = 2, setpoint = "q[" }]', "joints[1].setpoint", "no RTDE"),
    ],
)
def test_rtde_joint_mistakes_are_named(tmp_path: Path, joints: str, key: str, reason: str) -> None:
    found = problems(cell(tmp_path, 'type = "rtde"', f"{TWO}\njoints = {joints}"))
    assert any(k.endswith(key) and reason in r for k, r in found), found


def test_rtde_spellings_on_another_kind_and_a_missing_joint_list_are_named(
    tmp_path: Path,
) -> None:
    found = problems(cell(tmp_path, "", f'{TWO}\njoints = [{{ register = 1 }}, {{ node = "n" }}]'))
    assert ('robot[0] "r".joints[0].register', "only for RTDE sources: give node") in found
    found = problems(cell(tmp_path, 'type = "mqtt"', TWO))
    assert ('robot[0] "r".joints', "required: one entry per joint of the kinematics") in found


@pytest.mark.parametrize(
    ("source", "reason"),
    [
        ('type = "rtde"\nurl = "rtde://h/path"', "rtde://HOST[:PORT], nothing more"),
        ('type = "rtde"\nurl = "https://h"', "no RTDE address"),
        ('type = "mqtt"\nurl = "mqtt://viewer:secret@h"', "give the source's user"),
        ('type = "mqtt"\nurl = "tcp://h"', "no broker address"),
        ('type = "rtde"\nfrequency_hz = 1000', "less than or equal to 500"),
    ],
)
def test_source_mistakes_are_named_and_never_echo_a_password(
    tmp_path: Path, source: str, reason: str
) -> None:
    joints = 'joints = [{ node = "a" }, { node = "b" }]' if "mqtt" in source else ""
    found = problems(cell(tmp_path, source, f"{TWO}\n{joints}"))
    assert any(reason in r for _, r in found), found
    assert not any("secret" in r for _, r in found)


def test_mqtt_nodes_are_topics_with_optional_json_pointers(tmp_path: Path) -> None:
    joints = 'joints = [{ node = "plant/a" }, { node = "plant/state#/joints/1", unit = "rad" }]'
    (robot,) = load_cell(cell(tmp_path, 'type = "mqtt"', f"{TWO}\n{joints}"), env={}).robots
    assert [j.node for j in robot.joints] == ["plant/a", "plant/state#/joints/1"]
    assert [j.source_unit for j in robot.joints] == ["deg", "rad"]
    bad = 'joints = [{ node = "plant/+/a" }, { node = "plant/b" }]'
    found = problems(cell(tmp_path, 'type = "mqtt"', f"{TWO}\n{bad}"))
    assert any(k.endswith("joints[0].node") and "wildcards" in r for k, r in found), found
