"""Edits of a cell file's text keep everything they do not change: comments, order, layout.

Each edit is checked twice: the file read back (Python's own ``tomllib``) has
exactly the new values and every other value as before; and the text differs
from the original only on the lines the edit is about.
"""

from __future__ import annotations

import difflib
import tomllib
from pathlib import Path
from typing import Any

import pytest

from server.cell import load_cell
from server.cell.edit import CellText, EditError
from server.paths import DEMO_CELL

DEMO = DEMO_CELL.read_text()

SECTIONS = """\
# top comment
[[source]]
name = "s"   # the mock

[[robot]]
name = "r"  # the robot
source = "s"
kinematics = {type="type12"}
# joints follow
[[robot.joints]]
node = "a"
[[robot.joints]]
node = "b"
unit = "deg"

# next robot
[[robot]]
name = "g"
source = "s"
joints = [{node="q"}]
[robot.base]
xyz = [1, 2, 3]
# trailing comment of base

[robot.kinematics]
type = "axis_group"
[[robot.kinematics.axes]]
name = "a1"
# end of axes

# the end
"""


def changed_lines(before: str, after: str) -> list[str]:
    """The lines removed (-) and added (+)."""
    return [
        line[0] + line[2:].rstrip("\n")
        for line in difflib.ndiff(before.splitlines(True), after.splitlines(True))
        if line[:1] in "+-"
    ]


def comments(text: str) -> list[str]:
    return [line.strip() for line in text.splitlines() if line.strip().startswith("#")]


def test_a_joints_mapping_changes_that_entry_only() -> None:
    cell = CellText(DEMO)
    cell.set_joint("iiwa7", "a3", 2, {"scale": -1.0, "offset": 12.5})
    node = '    { node = "motion/axs/iiwa_a3/state/values/actual/pos", unit = "deg"%s },'
    assert changed_lines(DEMO, cell.text) == [
        "-" + node % "",
        "+" + node % ", scale = -1.0, offset = 12.5",
    ]
    before, after = tomllib.loads(DEMO), tomllib.loads(cell.text)
    after["robot"][1]["joints"][2] = {
        k: v for k, v in after["robot"][1]["joints"][2].items() if k not in ("scale", "offset")
    }
    assert after == before


def test_a_base_is_added_after_the_last_key_and_changed_where_it_is() -> None:
    cell = CellText(DEMO)
    cell.set_base("iiwa7", [1.0, 2.0, 3.00000000001], [0.0, 0.0, 90.0])
    cell.set_base("positioner", [1350.5, -0.0, 0.0], [0.0, 0.0, 10.0])
    assert changed_lines(DEMO, cell.text) == [
        "+base = { xyz = [1.0, 2.0, 3.0], rpy_deg = [0.0, 0.0, 90.0] }",
        "-base = { xyz = [1350.0, 0.0, 0.0] }",
        "+base = { xyz = [1350.5, 0.0, 0.0], rpy_deg = [0.0, 0.0, 10.0] }",
    ]
    # The new key went after iiwa7's last key, before its [robot.kinematics] section.
    lines = cell.text.splitlines()
    added = lines.index("base = { xyz = [1.0, 2.0, 3.0], rpy_deg = [0.0, 0.0, 90.0] }")
    assert lines[added - 1] == "]" and lines[added + 2] == "[robot.kinematics]"
    assert comments(cell.text) == comments(DEMO)


def test_an_axis_pose_changes_in_place() -> None:
    cell = CellText(DEMO)
    cell.set_axis_pose("positioner", "turn", [1.0, 2.0, 3.0], [4.0, 5.0, 6.0])
    assert changed_lines(DEMO, cell.text) == [
        "-pose = { xyz = [-100.0, 0.0, 0.0], rpy_deg = [0.0, -90.0, 0.0] }",
        "+pose = { xyz = [1.0, 2.0, 3.0], rpy_deg = [4.0, 5.0, 6.0] }",
    ]


def test_a_description_replaces_the_kinematics_keeping_the_comment_that_follows(
    tmp_path: Path,
) -> None:
    cell = CellText(DEMO)
    names = [f"j{i}" for i in range(1, 8)]
    by_joint = dict(zip([f"a{i}" for i in range(1, 8)], names, strict=True))
    cell.set_description("iiwa7", "arm.urdf", {"arm_description": "arm"}, by_joint)
    after = tomllib.loads(cell.text)
    iiwa = after["robot"][1]
    assert iiwa["kinematics"] == {
        "type": "urdf",
        "file": "arm.urdf",
        "packages": {"arm_description": "arm"},
    }
    assert [j["joint"] for j in iiwa["joints"]] == names and "mesh_dir" not in iiwa
    # The comment that introduced the positioner stays, right above it.
    assert comments(cell.text) == comments(DEMO)
    lines = cell.text.splitlines()
    intro = lines.index("# A MotionPlus axis group (Universal Robots): a tilt axis along +X, "
                        "450 mm up, carrying a turntable.")  # fmt: skip
    assert lines[intro + 1] == "[[robot]]" and lines[intro - 1] == ""
    assert lines[intro - 2].startswith('kinematics = { type = "urdf"')
    # Everything else is as it was.
    before = tomllib.loads(DEMO)
    for k in (0, 2):
        assert after["robot"][k] == before["robot"][k]
    assert after["source"] == before["source"]


def test_tables_written_as_sections_are_edited_as_sections() -> None:
    cell = CellText(SECTIONS)
    cell.set_joint("r", "a1", 1, {"scale": 2.0})
    cell.set_base("r", [1, 2, 3], [0, 0, 0])
    cell.set_base("g", [5, 6, 7], [0, 0, 1])
    cell.set_axis_pose("g", "a1", [1, 1, 1], [0, 0, 0])
    assert changed_lines(SECTIONS, cell.text) == [
        "+base = { xyz = [1.0, 2.0, 3.0], rpy_deg = [0.0, 0.0, 0.0] }",
        "+scale = 2.0",
        "-xyz = [1, 2, 3]",
        "+xyz = [5.0, 6.0, 7.0]",
        "+rpy_deg = [0.0, 0.0, 1.0]",
        "+pose = { xyz = [1.0, 1.0, 1.0], rpy_deg = [0.0, 0.0, 0.0] }",
    ]
    assert comments(cell.text) == comments(SECTIONS)
    # Each new key sits in its own table, before the comments that introduce the next.
    lines = cell.text.splitlines()
    assert lines[lines.index("+scale = 2.0"[1:]) - 1] == 'unit = "deg"'
    assert lines[lines.index('kinematics = {type="type12"}') + 1].startswith("base = ")
    parsed = tomllib.loads(cell.text)
    assert parsed["robot"][1]["kinematics"]["axes"][0]["pose"]["xyz"] == [1.0, 1.0, 1.0]


def test_a_description_of_an_axis_group_in_sections() -> None:
    cell = CellText(SECTIONS)
    cell.set_description("g", "y.urdf", {}, {"a1": "x"})
    parsed = tomllib.loads(cell.text)
    assert parsed["robot"][1]["kinematics"] == {"type": "urdf", "file": "y.urdf"}
    assert parsed["robot"][1]["joints"] == [{"node": "q", "joint": "x"}]
    assert comments(cell.text) == comments(SECTIONS)


def test_joints_named_by_the_entries_are_found_by_name() -> None:
    text = DEMO.replace(
        '{ node = "motion/axs/kin12_a0/state/values/actual/pos", unit = "deg" },\n'
        '    { node = "motion/axs/kin12_a1/state/values/actual/pos", unit = "deg" },',
        '{ node = "motion/axs/kin12_a1/state/values/actual/pos", unit = "deg", joint = "a1" },\n'
        '    { node = "motion/axs/kin12_a0/state/values/actual/pos", unit = "deg", joint = "a0" },',
    )
    cell = CellText(text)
    cell.set_joint("kin12", "a0", 0, {"offset": 5.0})
    assert tomllib.loads(cell.text)["robot"][0]["joints"][1]["offset"] == 5.0


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda c: c.set_joint("nobody", "a0", 0, {"scale": 1.0}), r"no \[\[robot\]\] named"),
        (lambda c: c.set_joint("kin12", "a9", 5, {"scale": 1.0}), "no joints entry"),
        (lambda c: c.set_axis_pose("kin12", "tilt", [0, 0, 0], [0, 0, 0]), "no axis 'tilt'"),
        (lambda c: c.set_description("kin12", "x.urdf", {}, {"a0": "a"}), "2 joints entries, 1"),
    ],
)
def test_edits_that_do_not_fit_the_file_say_why(edit: Any, message: str) -> None:
    with pytest.raises(EditError, match=message):
        edit(CellText(DEMO))


def test_text_that_is_not_toml_is_refused() -> None:
    with pytest.raises(EditError, match="not valid TOML"):
        CellText("[[robot]\nname = ")


def test_an_edited_demo_cell_still_loads(tmp_path: Path) -> None:
    cell = CellText(DEMO)
    cell.set_base("kin12", [-700.0, 300.0, 0.0], [0.0, 0.0, 45.0])
    cell.set_joint("kin12", "a0", 0, {"scale": -1.0})
    loaded = load_cell(DEMO_CELL, text=cell.text, cache_dir=tmp_path)
    kin12 = loaded.robots[0]
    assert kin12.joints[0].scale == -1.0
    assert kin12.base[:3] == pytest.approx((-0.7, 0.3, 0.0))
