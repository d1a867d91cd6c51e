"""The example plant (cells/examples/plant.toml: an OPC UA server, a ctrlX CORE, a UR controller
over RTDE and an MQTT broker, each its embedded mock) followed by a cluster's acquisition
worker and streamed to a viewer of a replica: every kind of source behind the same path."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

from tests.cluster._roles import ROOT, Cluster, RedisServer, all_live, wait_for, watch

PLANT = ROOT / "cells" / "examples" / "plant.toml"
FRAMES = 25
"""Frames messages of each source to see (a second of each at the source's 20 ms)."""


def plant_in(folder: Path) -> Path:
    """The example plant, its meshes where the copy can find them."""
    folder.mkdir()
    path = folder / "plant.toml"
    path.write_text(PLANT.read_text().replace('"../../assets/', f'"{ROOT / "assets"}/'))
    return path


async def test_every_kind_of_source_streams_through_a_worker(
    tmp_path: Path, redis_server: RedisServer
) -> None:
    roles = Cluster(tmp_path, redis_server.url, plant_in(tmp_path / "plant"))
    try:
        roles.worker("w1")
        replica = roles.replica("r1")
        health = await wait_for(replica, all_live)
        kinds = {s["name"]: s["url"].split(":", 1)[0] for s in health["sources"]}
        assert kinds == {"kuka": "opc.tcp", "ctrlx": "http", "ur": "rtde", "broker": "mqtt"}

        def enough(seen: object) -> bool:
            counts = Counter(i for _, i, _, _ in seen.frames)  # type: ignore[attr-defined]
            return len(counts) == 4 and min(counts.values()) >= FRAMES

        seen = await watch(replica.base, 60.0, until=enough)
        robots = [r["name"] for r in seen.hello["robots"]]
        assert sorted(robots) == ["feeder", "iiwa7", "kin12", "positioner", "ur5e"]
        counts = Counter(i for _, i, _, _ in seen.frames)
        assert len(counts) == 4 and min(counts.values()) >= FRAMES, counts
        # Each source's frames come in order, as the worker made them.
        for index in counts:
            seqs = [seq for _, i, seq, _ in seen.frames if i == index]
            assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)
    finally:
        roles.close()
