"""Mesh files a cell folder hands over are served only when they are GLBs inside that folder.

A hostile (or careless) cell folder: a ``mesh_dir`` entry that is a symlink to
``/etc/passwd``, one that leads out of the folder to a real GLB, one that is not
a GLB at all, and one that is a folder. Each is named by ``check``, drawn as a
stand-in, and answered 404 on ``/meshes``; the good ones are served as they are.
"""

from __future__ import annotations

import json
import shutil
import textwrap
from pathlib import Path

import aiohttp
from websockets.asyncio.client import connect as websockets_connect

from server.cell import load_cell
from server.cell.shown import relative_paths
from server.config import Settings
from tests.conftest import running_server
from tests.test_cli import run_server

ROOT = Path(__file__).resolve().parents[2]
KIN12_MESHES = ROOT / "assets" / "kin12"
CELL = """
[[source]]
name = "demo"

[[robot]]
name = "kin"
source = "demo"
kinematics = { type = "type12" }
joints = [ { node = "motion/axs/kin12_a0/state/values/actual/pos", unit = "deg" },
           { node = "motion/axs/kin12_a1/state/values/actual/pos", unit = "deg" } ]
mesh_dir = "meshes"
"""


def hostile_folder(tmp_path: Path) -> Path:
    """A cell whose links L1..L5 are: fine, /etc/passwd, out of the folder, text, a folder."""
    cell_dir, outside = tmp_path / "cell", tmp_path / "elsewhere"
    meshes = cell_dir / "meshes"
    meshes.mkdir(parents=True)
    outside.mkdir()
    shutil.copy(KIN12_MESHES / "L1.glb", meshes / "L1.glb")
    (meshes / "L5.glb").symlink_to("/etc/passwd")
    shutil.copy(KIN12_MESHES / "L4.glb", outside / "L4.glb")
    (meshes / "L4.glb").symlink_to(outside / "L4.glb")  # a real GLB, but not the cell's
    (meshes / "L2.glb").write_text("solid not-a-glb\n")
    path = cell_dir / "cell.toml"
    path.write_text(textwrap.dedent(CELL))
    return path


def test_files_that_are_not_glbs_in_their_folder_are_refused_with_a_warning(
    tmp_path: Path,
) -> None:
    path = hostile_folder(tmp_path)
    (robot,) = load_cell(path, env={}).robots
    assert robot.link_names == ("L1", "L5", "L4", "L2")
    assert robot.meshes[0] == path.parent / "meshes" / "L1.glb"
    assert robot.meshes[1:] == (None, None, None)  # stand-ins on the page
    passwd, outside, text = robot.warnings
    assert "L5.glb leads outside its folder" in passwd and "/etc/passwd" in passwd
    assert "L4.glb leads outside its folder" in outside
    assert "L2.glb is not a binary glTF file" in text
    checked = run_server("check", str(path))
    assert checked.returncode == 0, checked.stderr
    assert checked.stdout.count("warning:") == 3, checked.stdout


async def test_a_refused_file_is_never_served(tmp_path: Path) -> None:
    path = hostile_folder(tmp_path)
    answers = []
    async with running_server(Settings(cell=path)) as base, aiohttp.ClientSession() as http:
        for link in range(4):
            async with http.get(f"{base}/meshes/kin/{link}.glb") as resp:
                answers.append((resp.status, await resp.read()))
    assert answers[0] == (200, (KIN12_MESHES / "L1.glb").read_bytes())
    assert [status for status, _ in answers[1:]] == [404, 404, 404]
    assert all(b"root:" not in body for _, body in answers)


def test_a_symlink_within_the_folder_is_served(tmp_path: Path) -> None:
    path = hostile_folder(tmp_path)
    meshes = path.parent / "meshes"
    shutil.copy(KIN12_MESHES / "L4.glb", meshes / "shared.glb")
    (meshes / "L4.glb").unlink()
    (meshes / "L4.glb").symlink_to("shared.glb")
    (robot,) = load_cell(path, env={}).robots
    assert robot.meshes[2] == meshes / "L4.glb"
    assert not any("L4.glb" in w for w in robot.warnings)


async def test_viewers_see_the_cells_files_relative_to_its_folder(tmp_path: Path) -> None:
    path = hostile_folder(tmp_path)
    async with running_server(Settings(cell=path)) as base, aiohttp.ClientSession() as http:
        async with http.get(base + "/api/robots") as resp:
            (robot,) = await resp.json()
        async with http.get(base + "/api/health") as resp:
            health = await resp.json()
        async with websockets_connect(base.replace("http", "ws") + "/ws") as ws:
            hello = json.loads(await ws.recv())
            cell = json.loads(await ws.recv())
    assert health["cell"]["path"] == "cell.toml" and cell["path"] == "cell.toml"
    for warnings in (robot["warnings"], hello["robots"][0]["warnings"]):
        assert len(warnings) == 3
        assert all(str(tmp_path) not in w for w in warnings), warnings
        assert "mesh meshes/L2.glb is not a binary glTF file" in warnings[2], warnings
        assert "(to ../elsewhere/L4.glb)" in warnings[1], warnings


def test_only_paths_on_disk_are_made_relative(tmp_path: Path) -> None:
    (tmp_path / "cell" / "urdf").mkdir(parents=True)
    text = (
        f"{tmp_path}/cell/urdf/arm.urdf, line 3: mesh file {tmp_path}/cell/urdf/gone.stl not "
        "found (from 'package://arm/gone.stl'); see http://127.0.0.1:8000/api/robots and "
        "motion/axs/Axis_1/state/values/actual/pos or /api/health."
    )
    assert relative_paths(text, tmp_path / "cell") == (
        "urdf/arm.urdf, line 3: mesh file urdf/gone.stl not found (from "
        "'package://arm/gone.stl'); see http://127.0.0.1:8000/api/robots and "
        "motion/axs/Axis_1/state/values/actual/pos or /api/health."
    )
