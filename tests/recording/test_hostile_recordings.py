"""Replay of recordings it did not write: crafted MCAP files, a clock that stalls, a crash.

Files are made record by record with ``mcap``'s own record classes (or bytes
where a record must lie about its size); the reference for a crashed
recording is ``mcap``'s ``StreamReader``, which reads the same file as far as
it can. Every file lives in the test's temporary folder.
"""

from __future__ import annotations

import asyncio
import signal
import struct
import subprocess
import sys
import time
import tracemalloc
from collections.abc import Iterable
from pathlib import Path

import aiohttp
import numpy as np
import orjson
import pytest
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, DataEnd, Footer, Header, Message
from mcap.stream_reader import StreamReader

from server.cell import Robot
from server.config import Settings
from server.ctrlx import DataLayerError
from server.paths import DEMO_CELL
from server.recording import load_source, mcap_stream, replay
from server.recording.mcap_stream import MAX_CHUNK_BYTES
from server.runtime.startup import configured_cell
from tests.conftest import free_port, running_server
from tests.e2e.test_history import stream_frames

ROOT = Path(__file__).resolve().parent.parent.parent
MAGIC = b"\x89MCAP0\r\n"
ROBOTS = list(configured_cell(Settings()).robots_of("demo"))
KIN12 = "/kin12/joints"


def joints(seq: int, t: float, a0: float = 0.1, a1: float = -0.2) -> bytes:
    """A joints message of kin12 as the recorder writes it."""
    return orjson.dumps({"seq": seq, "t_source": t, "position": {"a0": a0, "a1": a1}})


def record(item: Header | Channel | Message | Chunk | DataEnd | Footer) -> bytes:
    builder = RecordBuilder()
    item.write(builder)
    return builder.end()


def mcap_file(path: Path, middle: Iterable[bytes], end: bool = True) -> Path:
    """Magic, header, the joints channel of kin12, ``middle``, then (``end``) the file's end."""
    parts = [MAGIC, record(Header(profile="", library="test")), channel_record()]
    parts += middle
    if end:
        parts += [record(DataEnd(0)), record(Footer(0, 0, 0)), MAGIC]
    path.write_bytes(b"".join(parts))
    return path


def channel_record() -> bytes:
    return record(Channel(id=1, topic=KIN12, message_encoding="json", schema_id=0, metadata={}))


def message_record(data: bytes, t: float = 1000.0) -> bytes:
    return record(
        Message(channel_id=1, sequence=0, log_time=int(t * 1e9), publish_time=0, data=data)
    )


def chunk_record(compressed: bytes, uncompressed_size: int) -> bytes:
    chunk = Chunk(
        compression="zstd",
        data=compressed,
        message_start_time=0,
        message_end_time=0,
        uncompressed_crc=0,
        uncompressed_size=uncompressed_size,
    )
    return record(chunk)


def bomb(messages: int) -> tuple[bytes, int]:
    """A zstd chunk of ``messages`` identical joints messages, compressed without holding them."""
    one = message_record(joints(1, 1000.0))
    compressor = zstandard.ZstdCompressor(level=19).compressobj()
    parts = [compressor.compress(channel_record())]
    block = one * 1000
    for _ in range(messages // 1000):
        parts.append(compressor.compress(block))
    parts.append(compressor.flush())
    return b"".join(parts), len(channel_record()) + len(block) * (messages // 1000)


def test_a_zstd_bomb_is_refused_by_its_size_without_decompressing_it(tmp_path: Path) -> None:
    compressed, size = bomb(2_000_000)  # 2 M messages, 27 KB: the file
    path = mcap_file(tmp_path / "bomb.mcap", [chunk_record(compressed, size)])
    assert path.stat().st_size < 100_000 and size > 100_000_000
    tracemalloc.start()
    try:
        with pytest.raises(DataLayerError) as refused:
            load_source(path, "demo", ROBOTS)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert f"decompresses to {size} bytes, over the limit of {MAX_CHUNK_BYTES}" in str(
        refused.value
    )
    assert peak < 5_000_000


def test_a_bomb_that_hides_its_size_is_cut_at_the_size_it_claims(tmp_path: Path) -> None:
    compressed, size = bomb(2_000_000)
    good = [message_record(joints(n, 1000.0 + 0.02 * n)) for n in range(1, 51)]
    claims = 1 << 20  # a chunk "of 1 MiB" that holds 100 times more
    path = mcap_file(tmp_path / "liar.mcap", [*good, chunk_record(compressed, claims)])
    tracemalloc.start()
    try:
        source = load_source(path, "demo", ROBOTS)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(source.t) == 50, "what came before the lying chunk is replayed"
    assert source.warning is not None and "cut short" in source.warning
    assert f"not the {claims} it claims" in source.warning
    assert peak < 4 * claims + 20_000_000


def test_records_claiming_2_62_bytes_allocate_nothing(tmp_path: Path) -> None:
    good = [message_record(joints(n, 1000.0 + 0.02 * n)) for n in range(1, 21)]
    # A chunk record of honest outer length whose data field claims 2^62 bytes.
    inner = struct.pack("<QQQI", 0, 0, 1 << 20, 0) + struct.pack("<I", 4) + b"zstd"
    inner += struct.pack("<Q", 1 << 62) + b"\0" * 64
    lying_chunk = struct.pack("<BQ", Opcode.CHUNK, len(inner)) + inner
    source = load_source(mcap_file(tmp_path / "inner.mcap", [*good, lying_chunk]), "demo", ROBOTS)
    assert len(source.t) == 20 and "cut short" in (source.warning or "")
    assert f"{1 << 62} more bytes claimed" in (source.warning or "")
    # A record whose own length is 2^62 (foxglove-sdk's writer leaves 2^64 - 1 in a chunk it
    # has not finished): the file is cut there.
    huge = struct.pack("<BQ", Opcode.CHUNK, 1 << 62) + b"\0" * 64
    source = load_source(mcap_file(tmp_path / "outer.mcap", [*good, huge]), "demo", ROBOTS)
    assert len(source.t) == 20 and "a record runs past the end" in (source.warning or "")


def test_a_record_over_the_limit_within_the_file_refuses_it_with_the_number(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(mcap_stream, "MAX_RECORD_BYTES", 1000)
    big = message_record(joints(1, 1000.0) + b" " * 2000)
    with pytest.raises(DataLayerError, match="a record of [0-9]+ bytes, over the limit of 1000"):
        load_source(mcap_file(tmp_path / "big.mcap", [big]), "demo", ROBOTS)


def test_bad_messages_are_refused_one_by_one_and_named(tmp_path: Path) -> None:
    good = [joints(n, 1000.0 + 0.02 * n) for n in range(1, 31)]
    bad = [
        b'{"seq": 18446744073709551616, "t_source": 1001.0, "position": {"a0": 0, "a1": 0}}',
        joints(1 << 63, 1001.0),  # beyond int64 too
        joints(-1, 1001.0),
        b'{"seq": 40, "t_source": Infinity, "position": {"a0": 0, "a1": 0}}',
        b'{"seq": 41, "t_source": 1e400, "position": {"a0": 0, "a1": 0}}',  # inf when parsed
        joints(42, 1e300),  # finite, but no Unix time
        orjson.dumps({"seq": 43, "t_source": 1001.0, "position": {"a0": None, "a1": 0}}),
        orjson.dumps({"seq": 44, "t_source": 1001.0, "position": {"a0": 0.0}}),
        orjson.dumps([1, 2]),
    ]
    records = [message_record(data) for data in good[:15] + bad + good[15:]]
    source = load_source(mcap_file(tmp_path / "bad.mcap", records), "demo", ROBOTS)
    assert source.seq.tolist() == list(range(1, 31))
    assert source.warning is not None and source.warning.startswith("9 messages refused")
    for reason in (
        "seq not an integer within int64: 3",
        "not JSON: 2",
        "t_source not a finite Unix time: 1",
        "a joint missing or not a number: 2",
        "not a joints message: 1",
    ):
        assert reason in source.warning


def test_more_messages_than_the_limit_refuse_the_file_with_the_number(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(replay, "MAX_MESSAGES", 100)
    records = [message_record(joints(n, 1000.0 + 0.02 * n)) for n in range(1, 151)]
    with pytest.raises(DataLayerError, match="holds more than 100 joint messages"):
        load_source(mcap_file(tmp_path / "many.mcap", records), "demo", ROBOTS)


async def samples_in(path: Path, seconds: float) -> list[float]:
    """The times of the samples ``play`` yields in ``seconds``."""
    source = load_source(path, "demo", ROBOTS)
    times: list[float] = []
    with pytest.raises(TimeoutError):
        async with asyncio.timeout(seconds):
            async for sample in source.play():
                times.append(sample.t_source)
    return times


@pytest.mark.parametrize("clock", ["stalled", "backwards"])
async def test_a_clock_that_stalls_or_steps_back_is_paced_not_spun(
    tmp_path: Path, clock: str
) -> None:
    def t(n: int) -> float:
        return 1000.0 if clock == "stalled" else 2000.0 - 0.02 * n

    records = [message_record(joints(n, t(n))) for n in range(1, 501)]
    path = mcap_file(tmp_path / f"{clock}.mcap", records)
    times = await samples_in(path, 1.0)
    # Paced at the default period, 0.02 s: about 50 in a second (the issue: 18 667).
    assert 10 <= len(times) <= 1.0 / 0.02 + 3
    assert times[:3] == [t(1), t(2), t(3)], "each sample keeps its recorded time"


def test_the_crash_test_recording_has_whole_chunks(tmp_path: Path) -> None:
    """(Sanity of the reference below: the library reads a cut file up to the cut.)"""
    records = [message_record(joints(n, 1000.0 + 0.02 * n)) for n in range(1, 11)]
    path = mcap_file(tmp_path / "whole.mcap", records)
    assert reference_count(path) == 10


def reference_count(path: Path) -> int:
    """Joint messages ``mcap``'s StreamReader reads before the file ends (or breaks)."""
    topics: dict[int, str] = {}
    count = 0
    with path.open("rb") as f:
        try:
            for item in StreamReader(f).records:
                if isinstance(item, Channel):
                    topics[item.id] = item.topic
                elif isinstance(item, Message) and topics[item.channel_id].endswith("/joints"):
                    count += 1
        except (McapError, struct.error, ValueError, zstandard.ZstdError):
            pass
    return count


async def test_a_recording_cut_by_kill_9_replays_up_to_its_last_complete_chunk(
    tmp_path: Path,
) -> None:
    folder = tmp_path / "rec"
    log = (tmp_path / "server.log").open("wb")
    recorder = subprocess.Popen(
        [sys.executable, "-m", "server", "--record", str(folder), "--port", str(free_port())],
        cwd=ROOT,
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    try:
        deadline = time.monotonic() + 120
        # The first chunk holds the meshes, each next one about 5 s of samples: wait for one.
        while sum(reference_count(f) for f in folder.glob("*.mcap")) < 100:
            assert time.monotonic() < deadline and recorder.poll() is None, "nothing recorded"
            await asyncio.sleep(0.5)
        await asyncio.sleep(2.0)
    finally:
        recorder.send_signal(signal.SIGKILL)
        recorder.wait(10)
        log.close()
    (path,) = folder.glob("*.mcap")
    expected = reference_count(path)
    assert expected >= 100
    source = load_source(path, "demo", ROBOTS)
    assert sum(rows_of(source, robot) for robot in ROBOTS) == expected
    assert source.warning is not None and "cut short" in source.warning
    # Served as if live: the page gets its frames.
    async with running_server(Settings(replay=path, cell=DEMO_CELL)) as base:
        frames = await stream_frames(base, 20)
        async with aiohttp.ClientSession() as http, http.get(f"{base}/api/health") as r:
            health = await r.json()
    assert len(frames) == 20
    (status,) = health["sources"]
    assert status["state"] == "connected" and "cut short" in (status["warning"] or "")


def rows_of(source: replay.SourceReplay, robot: Robot) -> int:
    """Samples of ``source`` in which ``robot``'s joints were recorded."""
    columns = [source.nodes.index(n) for n in robot.nodes]
    return int((~np.isnan(source.values[:, columns]).any(axis=1)).sum())
