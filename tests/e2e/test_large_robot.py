"""The largest robot linkview takes (256 movable joints, 2 048 links) on every path a robot takes:
the binary stream (joint counts above 255), /fk and /ik, the Foxglove endpoint, a saved
recording and its replay."""

from __future__ import annotations

import re
from pathlib import Path

import aiohttp
import numpy as np
import pytest

from server.cell import load_cell
from server.config import Settings
from server.sizes import MAX_JOINTS, MAX_LINKS
from tests.conftest import free_port, running_server
from tests.e2e.test_foxglove import subscribe_and_collect
from tests.e2e.test_history import stream_frames
from tests.urdf.corpus import tree_urdf


def largest_cell(folder: Path) -> Path:
    """A cell of one robot of MAX_JOINTS joints and MAX_LINKS links (no visuals: no meshes)."""
    urdf = re.sub(r"<visual>.*?</visual>", "", tree_urdf(MAX_LINKS, MAX_JOINTS))
    (folder / "big.urdf").write_text(urdf)
    joints = ", ".join(f'{{ node = "motion/axs/A{k}/state/values/actual/pos", unit = "rad" }}'
                       for k in range(MAX_JOINTS))  # fmt: skip
    cell = folder / "cell.toml"
    cell.write_text(
        '[[source]]\nname = "mock"\n\n[[robot]]\nname = "big"\nsource = "mock"\n'
        f'kinematics = {{ type = "urdf", file = "big.urdf" }}\njoints = [ {joints} ]\n'
    )
    return cell


def assert_largest(frames: list) -> None:  # type: ignore[type-arg]
    robots = [robot for frame in frames for robot in frame.robots if robot.ok]
    assert robots
    for robot in robots:
        assert robot.joints.shape == (MAX_JOINTS,) and robot.links.shape == (MAX_LINKS, 7)


async def test_the_largest_robot_streams_answers_records_and_replays(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("LINKVIEW_CACHE_DIR", str(tmp_path / "cache"))  # the replay loads the cell
    cell = load_cell(largest_cell(tmp_path), env={}, cache_dir=tmp_path / "cache")
    port = free_port()
    async with (
        running_server(Settings(foxglove_port=port), cell) as base,
        aiohttp.ClientSession() as http,
    ):
        assert_largest(await stream_frames(base, 20))
        q = np.random.default_rng(0).uniform(-0.5, 0.5, MAX_JOINTS)
        async with http.post(f"{base}/api/robots/big/fk", json={"joints": [q.tolist()]}) as r:
            assert r.status == 200, await r.text()
            forward = await r.json()
        tcp = forward["tcp"][0]
        ik = {"tcp": tcp, "joints_ref": (q + 0.01).tolist()}
        async with http.post(f"{base}/api/robots/big/ik", json=ik) as r:
            assert r.status == 200, await r.text()
            inverse = await r.json()
        assert inverse["ok"] and len(inverse["best"]) == MAX_JOINTS
        _, received = await subscribe_and_collect(f"ws://127.0.0.1:{port}/", "/tf", 6)
        # The base in the world, and a message of every link's transform per sample.
        sizes = sorted({len(message.transforms) for _, message in received})
        assert sizes[-1] == MAX_LINKS + 1, sizes  # with the TCP frame
        async with http.post(f"{base}/api/history/recording", json={"minutes": 1}) as r:
            assert r.status == 200
            saved = tmp_path / "saved.mcap"
            saved.write_bytes(await r.read())
    async with running_server(Settings(replay=saved)) as base:
        assert_largest(await stream_frames(base, 10))
