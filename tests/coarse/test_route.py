"""``GET /meshes/{robot}/{link}.glb?detail=coarse``: the 2D view's link meshes, over HTTP."""

from __future__ import annotations

import shutil
from pathlib import Path

import aiohttp

from server.cell import load_cell
from server.coarse import coarse_glb
from server.config import Settings
from tests.conftest import running_server

ROOT = Path(__file__).resolve().parents[2]

CELL = """
[[source]]
name = "mock"

[[robot]]
name = "kin"
source = "mock"
kinematics = { type = "type12", L1 = 200.0, L2 = 150.0, L3 = 100.0, L4 = 200.0, L5 = 100.0 }
joints = [
    { node = "motion/axs/kin_a0/state/values/actual/pos", unit = "deg" },
    { node = "motion/axs/kin_a1/state/values/actual/pos", unit = "deg" },
]
mesh_dir = "meshes"
"""


async def get(url: str) -> tuple[int, str, bytes]:
    async with aiohttp.ClientSession() as session, session.get(url) as response:
        return response.status, response.content_type, await response.read()


async def test_coarse_link_meshes_are_served_and_a_broken_one_is_refused(tmp_path: Path) -> None:
    shutil.copytree(ROOT / "assets" / "kin12", tmp_path / "meshes")
    (tmp_path / "cell.toml").write_text(CELL)
    cell = load_cell(tmp_path / "cell.toml", cache_dir=tmp_path / "cache")
    async with running_server(Settings(), cell) as base:
        status, kind, full = await get(f"{base}/meshes/kin/0.glb")
        assert (status, kind) == (200, "model/gltf-binary")
        assert full == (tmp_path / "meshes" / "L1.glb").read_bytes()
        status, kind, coarse = await get(f"{base}/meshes/kin/0.glb?detail=coarse")
        assert (status, kind) == (200, "model/gltf-binary")
        assert coarse == coarse_glb(full) and len(coarse) < len(full) / 2
        status, _, _ = await get(f"{base}/meshes/kin/0.glb?detail=everything")
        assert status == 422
        # A file that passes for a GLB (its magic) but is none: served as is, no coarse copy.
        (tmp_path / "meshes" / "L2.glb").write_bytes(b"glTF" + b"\xff" * 64)  # link 3
        status, _, body = await get(f"{base}/meshes/kin/3.glb?detail=coarse")
        assert status == 404
        assert b"no coarse mesh for link 3 of 'kin': cannot read it as a GLB" in body
        status, _, body = await get(f"{base}/meshes/kin/3.glb")
        assert status == 200
        status, _, body = await get(f"{base}/meshes/kin/0.glb?detail=coarse")  # the others live on
        assert status == 200 and body == coarse
