"""Picking a description: the ones on this machine with the robot's number of joints, previewed,
and chosen into the cell file (its file and joint order).

Searched: the cell's folder (a copy of a test URDF, a xacro macro library, a
two-joint file), the Python environment (the test extras install published
descriptions: airo-models' UR arms have 6 joints), and a ROS package path
given in ``ROS_PACKAGE_PATH``. The preview's link poses are checked against
yourdfpy's own forward kinematics of the file.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import aiohttp
import numpy as np
import pytest
import yourdfpy
from scipy.spatial.transform import Rotation

from server.cell import CellError, load_cell
from server.config import Settings
from tests.commissioning.cells import SOURCE, TODO_ARM, TODO_URDF_ARM
from tests.conftest import running_server

FIXTURES = Path(__file__).resolve().parents[1] / "urdf" / "fixtures"

CELL = "allow_edits = true\n\n" + SOURCE + TODO_ARM

TWO_JOINTS = """<robot name="two">
  <link name="a"/><link name="b"/><link name="c"/>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="prismatic"><parent link="b"/><child link="c"/>
    <axis xyz="0 0 1"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""
MACROS = """<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="l" value="0.3"/>
  <xacro:macro name="arm"><link name="x"/></xacro:macro>
</robot>
"""
PACKAGE = '<package format="3"><name>{name}</name><version>1.0.0</version></package>\n'


@pytest.fixture
def machine(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A cell folder with descriptions in it, and a ROS package path beside it."""
    folder = tmp_path / "cell"
    (folder / "arm").mkdir(parents=True)
    (folder / "cell.toml").write_text(CELL)
    shutil.copy(FIXTURES / "serial6.urdf", folder / "arm" / "serial6.urdf")
    (folder / "arm" / "two.urdf").write_text(TWO_JOINTS)
    (folder / "arm" / "macros.xacro").write_text(MACROS)
    package = tmp_path / "ros" / "src" / "six_description"
    (package / "urdf").mkdir(parents=True)
    (package / "package.xml").write_text(PACKAGE.format(name="six_description"))
    shutil.copy(FIXTURES / "serial6.urdf", package / "urdf" / "six.urdf")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ros" / "src"))
    monkeypatch.setenv("LINKVIEW_CACHE_DIR", str(tmp_path / "cache"))  # meshes of the chosen
    return folder


async def get(http: aiohttp.ClientSession, url: str) -> Any:
    async with http.get(url) as response:
        answer = await response.json()
        assert response.status == 200, answer
        return answer


async def change(http: aiohttp.ClientSession, base: str, made: dict[str, Any]) -> Any:
    """``POST /api/cell/changes`` with one change; the cell's state after it (200 expected)."""
    async with http.post(f"{base}/api/cell/changes", json={"changes": [made]}) as response:
        answer = await response.json()
        assert response.status == 200, answer
        return answer


def matrix(pose7: list[float]) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_quat(pose7[3:]).as_matrix()
    pose[:3, 3] = pose7[:3]
    return pose


async def test_descriptions_with_the_robots_joints_are_found_previewed_and_chosen(
    machine: Path,
) -> None:
    cell = machine / "cell.toml"
    async with running_server(Settings(cell=cell)) as base, aiohttp.ClientSession() as http:
        listing = await get(http, f"{base}/api/descriptions?robot=arm")
        found = {(d["origin"], d["file"]): d for d in listing["found"]}
        assert listing["joints"] == 6 and listing["pending"] == 0
        assert all(len(d["joints"]) == 6 for d in listing["found"])
        mine = found["cell folder", "arm/serial6.urdf"]
        assert mine["joints"] == ["j1", "j2", "j3", "j4", "j5", "j6"]
        assert not any(d["name"] in ("two.urdf", "macros.xacro") for d in listing["found"])
        assert any(o == "ROS packages" and f.endswith("six_description/urdf/six.urdf")
                   for o, f in found)  # fmt: skip
        # A published arm description that pip installed (airo-models' UR3e, UR5e).
        assert any(o == "Python environment" and "airo_models" in f for o, f in found)
        # The cell folder's are listed first.
        assert listing["found"][0]["origin"] == "cell folder"

        shown = await get(http, f"{base}/api/descriptions/{mine['id']}")
        urdf = yourdfpy.URDF.load(str(FIXTURES / "serial6.urdf"), load_meshes=False)
        assert [j["name"] for j in shown["joints"]] == urdf.actuated_joint_names
        for link in shown["links"]:
            np.testing.assert_allclose(
                matrix(link["pose"]), urdf.get_transform(link["name"]), atol=1e-12
            )
        async with http.get(f"{base}/api/descriptions/0123456789abcdef") as response:
            assert response.status == 404

        order = ["j1", "j2", "j3", "j4", "j6", "j5"]  # the last two nodes swapped round
        choose = {"op": "description", "robot": "arm", "id": mine["id"], "joints": order}
        status = await change(http, base, choose)
        diff = status["unsaved"]["diff"]
        assert '+kinematics = { type = "urdf", file = "arm/serial6.urdf" }' in diff
        assert '+    { node = "motion/axs/A5/state/values/actual/pos", joint = "j6" },' in diff
        robots = await get(http, f"{base}/api/robots")
        (arm,) = robots
        assert arm["kinematics"] == "urdf"
        # Joints come in the URDF's order, each read from the node that names it.
        assert [j["name"] for j in arm["joints"]] == urdf.actuated_joint_names
        assert [j["node"].split("/")[2] for j in arm["joints"]] == [
            "A1", "A2", "A3", "A4", "A6", "A5"
        ]  # fmt: skip
        # A wrong order is refused.
        wrong = {**choose, "joints": ["j1", "j1", "j2", "j3", "j4", "j5"]}
        async with http.post(f"{base}/api/cell/changes", json={"changes": [wrong]}) as response:
            assert response.status == 422
            assert "each once" in (await response.json())["detail"]


async def test_a_ros_description_names_the_packages_only_the_ros_path_knows(
    machine: Path,
) -> None:
    package = machine.parent / "ros" / "src" / "six_description"
    meshes = machine.parent / "ros" / "src" / "six_meshes"
    (meshes / "meshes").mkdir(parents=True)
    (meshes / "package.xml").write_text(PACKAGE.format(name="six_meshes"))
    shutil.copy(FIXTURES / "mesh_description" / "meshes" / "base.stl", meshes / "meshes")
    six = package / "urdf" / "six.urdf"
    six.write_text(
        six.read_text().replace(
            '<cylinder radius="0.1" length="0.05"/>',
            '<mesh filename="package://six_meshes/meshes/base.stl"/>',
        )
    )
    cell = machine / "cell.toml"
    async with running_server(Settings(cell=cell)) as base, aiohttp.ClientSession() as http:
        listing = await get(http, f"{base}/api/descriptions?robot=arm")
        (ros,) = [d for d in listing["found"] if d["origin"] == "ROS packages"]
        choose = {"op": "description", "robot": "arm", "id": ros["id"]}
        status = await change(http, base, choose)
        assert f'packages = {{ six_meshes = "{meshes}" }}' in status["unsaved"]["diff"]


async def test_a_robot_whose_urdf_is_not_there_runs_as_a_placeholder_where_edits_are_allowed(
    machine: Path, tmp_path: Path
) -> None:
    cell = machine / "cell.toml"
    cell.write_text(SOURCE + TODO_URDF_ARM)
    # `check` and a server that may not edit name the missing file, as before.
    with pytest.raises(CellError, match=r"kinematics\.file: URDF file .*arm\.urdf not found"):
        load_cell(cell, cache_dir=tmp_path / "cache")
    async with running_server(Settings(cell=cell, allow_edits=True)) as base:
        async with aiohttp.ClientSession() as http:
            (arm,) = await get(http, f"{base}/api/robots")
            assert [j["name"] for j in arm["joints"]] == ["j1", "j2", "j3", "j4", "j5", "j6"]
            assert "arm.urdf is not there: drawn as a placeholder chain" in arm["warnings"][0]
            listing = await get(http, f"{base}/api/descriptions?robot=arm")
            (mine,) = [d for d in listing["found"] if d["file"] == "arm/serial6.urdf"]
            choose = {"op": "description", "robot": "arm", "id": mine["id"]}
            status = await change(http, base, choose)
            diff = status["unsaved"]["diff"]
            assert '-kinematics = { type = "urdf", file = "arm.urdf" }' in diff
            assert '+kinematics = { type = "urdf", file = "arm/serial6.urdf" }' in diff
            (arm,) = await get(http, f"{base}/api/robots")
            assert arm["warnings"] == [] and len(arm["links"]) == 9
