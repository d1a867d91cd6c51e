"""Recordings read back with the ``mcap`` reader, and replayed: the page gets the same frames."""

from __future__ import annotations

import asyncio
from collections import defaultdict
from pathlib import Path
from typing import Any

import aiohttp
import numpy as np
import orjson
import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from server.config import Settings
from server.ctrlx import Sample
from server.history import History
from server.paths import DEMO_CELL
from server.protocol import Frames2
from server.recording import Recorder
from server.runtime.startup import configured_cell
from tests.conftest import running_server
from tests.e2e.test_history import stream_frames

ROBOTS = ("kin12", "iiwa7", "positioner")


async def record(tmp_path: Path, seconds_of_frames: int = 60) -> tuple[Path, list[Frames2]]:
    """Run the demo, watch its stream, save the history with the page's record button."""
    async with running_server(Settings()) as base, aiohttp.ClientSession() as http:
        frames = await stream_frames(base, seconds_of_frames)
        await asyncio.sleep(0.3)
        async with http.post(f"{base}/api/history/recording", json={"minutes": 1}) as r:
            assert r.status == 200
            assert "attachment" in r.headers["content-disposition"]
            path = tmp_path / "saved.mcap"
            path.write_bytes(await r.read())
        return path, frames


def read(path: Path) -> tuple[Any, dict[str, list[tuple[int, Any]]]]:
    """The summary, and every decoded message per topic with its log time."""
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        messages: dict[str, list[tuple[int, Any]]] = defaultdict(list)
        for _, channel, message in reader.iter_messages():
            messages[channel.topic].append((message.log_time, message.data))
        f.seek(0)
        attachments = list(make_reader(f).iter_attachments())
    summary.attachments = attachments
    return summary, messages


def decode(path: Path, topic: str) -> list[Any]:
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [m for _, _, _, m in reader.iter_decoded_messages(topics=[topic])]


async def test_a_saved_recording_opens_with_foxglove_schemas_poses_meshes_and_cell(
    tmp_path: Path,
) -> None:
    async with running_server(Settings()) as base, aiohttp.ClientSession() as http:
        await stream_frames(base, 40)
        async with http.post(f"{base}/api/history/recording", json={"minutes": 1}) as r:
            assert r.status == 200 and "attachment" in r.headers["content-disposition"]
            path = tmp_path / "saved.mcap"
            path.write_bytes(await r.read())
        summary, messages = read(path)
        joints = [orjson.loads(data) for _, data in messages["/iiwa7/joints"]]
        rows = [[j["position"][f"a{i}"] for i in range(1, 8)] for j in joints[:25]]
        body = {"joints": rows, "links": True}
        async with http.post(f"{base}/api/robots/iiwa7/fk", json=body) as r:
            fk = await r.json()

    schemas = {summary.schemas[c.schema_id].name for c in summary.channels.values()}
    topics = {c.topic for c in summary.channels.values()}
    assert {"foxglove.FrameTransforms", "foxglove.SceneUpdate", "foxglove.Log"} <= schemas
    assert topics == {"/tf", "/scene", "/log", *(f"/{r}/joints" for r in ROBOTS)}
    assert summary.statistics.message_count > 100 and len(summary.chunk_indexes) >= 1
    assert all(c.compression == "zstd" for c in summary.chunk_indexes)
    (attachment,) = summary.attachments
    assert attachment.name == "demo.toml" and attachment.data == DEMO_CELL.read_bytes()

    (scene,) = decode(path, "/scene")
    cell = configured_cell(Settings())
    meshes = {
        f"{r.name}/{n}": m for r in cell.robots for n, m in zip(r.link_names, r.meshes, strict=True)
    }
    assert {e.frame_id for e in scene.entities} == set(meshes)
    for entity in scene.entities:
        (model,) = entity.models
        assert model.media_type == "model/gltf-binary"
        assert model.data == meshes[entity.frame_id].read_bytes()

    # Link transforms of the recorded joints equal /fk of the same joints.
    by_time = {}
    for message in decode(path, "/tf"):
        parents = {t.parent_frame_id for t in message.transforms}
        if parents == {"iiwa7/base"}:
            first = message.transforms[0].timestamp
            by_time[first.seconds + first.nanos * 1e-9] = message
    assert len(joints) >= 25 and len(by_time) >= len(joints) - 1
    link_names = [f"iiwa7/{n}" for n in cell.robots[1].link_names]
    for k, recorded in enumerate(joints[:25]):
        (time_key,) = [t for t in by_time if abs(t - recorded["t_source"]) < 1e-6]
        transforms = {t.child_frame_id: t for t in by_time[time_key].transforms}
        for i, name in enumerate(link_names):
            tr = transforms[name]
            got = [tr.translation.x, tr.translation.y, tr.translation.z]
            got += [tr.rotation.x, tr.rotation.y, tr.rotation.z, tr.rotation.w]
            np.testing.assert_allclose(got, fk["links"][k][i], atol=2e-6, rtol=0)
        # The arm's TCP is its last link: that frame carries it (fixed, below).
        last = transforms[link_names[-1]].translation
        np.testing.assert_allclose([last.x, last.y, last.z], fk["tcp"][k][:3], atol=2e-6)
    (fixed,) = [m for m in decode(path, "/tf") if m.transforms[0].parent_frame_id == "world"]
    parents = {t.child_frame_id: t.parent_frame_id for t in fixed.transforms}
    assert {f"{r}/base" for r in ROBOTS} <= set(parents)
    assert parents["iiwa7/tcp"] == link_names[-1] and cell.robots[1].tcp_is_last_link


F32_EPS = float(np.finfo(np.float32).eps)


async def test_replay_serves_the_frames_the_stream_sent_when_recording(tmp_path: Path) -> None:
    path, recorded = await record(tmp_path, 60)
    by_time = {f.t_source: f for f in recorded}
    async with running_server(Settings(replay=path)) as base, aiohttp.ClientSession() as http:
        replayed = await stream_frames(base, 80)
        async with http.get(f"{base}/api/history") as response:
            summary = await response.json()
        async with http.get(f"{base}/api/health") as response:
            health = await response.json()
        async with http.post(f"{base}/api/robots/kin12/move", json={"joints": [0, 0]}) as r:
            assert r.status == 403  # a recording cannot be moved
    (source,) = summary["sources"]
    assert source["replay"] is True and source["from"] <= recorded[0].t_source
    assert health["sources"][0]["url"] == "replay:saved.mcap"
    matched = 0
    for frame in replayed:
        sent = by_time.get(frame.t_source)
        if sent is None:
            continue
        matched += 1
        assert [r.robot_index for r in frame.robots] == [r.robot_index for r in sent.robots]
        for a, b in zip(frame.robots, sent.robots, strict=True):
            assert a.ok == b.ok
            # Protocol 2 carries float32, and the replay rounds what it recomputed once more:
            # the two agree to one float32 step at the largest value (the largest difference
            # seen was 1.2e-7, on a joint near 2 rad; links and TCP 6e-8).
            for replayed, sent in ((a.joints, b.joints), (a.links, b.links), (a.tcp, b.tcp)):
                step = F32_EPS * max(1.0, float(np.abs(sent).max(initial=0.0)))
                np.testing.assert_allclose(replayed, sent, atol=step, rtol=0)
    assert matched >= 40, f"only {matched} replayed frames were among the recorded ones"


async def test_continuous_recording_rotates_files_that_a_reader_can_index(tmp_path: Path) -> None:
    async with running_server(Settings(record=tmp_path / "rec")) as base:
        await stream_frames(base, 80)
    (path,) = sorted((tmp_path / "rec").glob("*.mcap"))
    summary, messages = read(path)
    assert summary is not None and summary.chunk_indexes, "no index: the file was not closed"
    assert len(messages["/iiwa7/joints"]) >= 60
    # Rotation: a new file once the current one is too big.
    history = History(seconds=5.0)
    cell = configured_cell(Settings())
    source = history.source("demo", [n for r in cell.robots for n in r.nodes], 0.02)
    recorder = Recorder(history, lambda: cell, tmp_path / "rotated", max_file_bytes=1)
    nodes = source.ring.nodes
    for step in range(3):
        for k in range(10):
            seq = step * 10 + k
            source.sample(seq, Sample(1000.0 + seq * 0.02, {n: 1.0 for n in nodes}))
        await recorder.drain()
    recorder.file.close()  # type: ignore[union-attr]
    files = sorted((tmp_path / "rotated").glob("*.mcap"))
    assert len(files) == 3 == len(recorder.files)
    counts = [len(read(f)[1]["/kin12/joints"]) for f in files]
    assert counts == [10, 10, 10]


def test_replay_needs_a_cell_it_can_find_and_says_so(tmp_path: Path) -> None:
    import dataclasses
    import subprocess
    import sys

    from server.cell import CellError
    from server.recording import McapFile, replay_cell

    missing = tmp_path / "nope.mcap"
    with pytest.raises(CellError, match="no such file"):
        replay_cell(missing)
    demo = configured_cell(Settings())
    anonymous = tmp_path / "anonymous.mcap"
    McapFile(anonymous, dataclasses.replace(demo, path=None)).close()
    with pytest.raises(CellError, match="give the cell with --cell"):
        replay_cell(anonymous)
    cell = replay_cell(anonymous, DEMO_CELL)
    assert [s.replay for s in cell.sources] == [anonymous.resolve()]
    assert all(s.url is None for s in cell.sources)
    started = subprocess.run(
        [sys.executable, "-m", "server", "--replay", str(missing), "--port", "0"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert started.returncode == 2 and "nope.mcap: (recording): no such file" in started.stderr
    assert "Traceback" not in started.stderr
