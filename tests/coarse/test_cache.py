"""Coarse meshes are made once per file content, in a worker thread, and served from memory."""

from __future__ import annotations

import asyncio
import shutil
import threading
from pathlib import Path

import pytest

from server.coarse import CoarseError, CoarseMeshes, coarse_glb

ASSETS = Path(__file__).resolve().parents[2] / "assets"


async def test_one_conversion_per_content_however_many_ask(tmp_path: Path) -> None:
    first = tmp_path / "a.glb"
    shutil.copy(ASSETS / "kin12" / "L1.glb", first)
    copy = tmp_path / "b.glb"
    shutil.copy(first, copy)
    cache = CoarseMeshes()
    answers = await asyncio.gather(*(cache.get(path) for path in [first, copy] * 5))
    assert cache.conversions == 1
    assert all(answer == coarse_glb(first.read_bytes()) for answer in answers)
    # A changed file is new content: converted again.
    shutil.copy(ASSETS / "kin12" / "L5.glb", first)
    assert await cache.get(first) == coarse_glb(first.read_bytes())
    assert cache.conversions == 2


async def test_conversions_run_beside_the_event_loop_one_at_a_time(tmp_path: Path) -> None:
    paths = []
    for k, name in enumerate(["L1", "L2", "L4", "L5"]):
        paths.append(tmp_path / f"{k}.glb")
        shutil.copy(ASSETS / "kin12" / f"{name}.glb", paths[-1])
    cache = CoarseMeshes()
    loop_thread = threading.get_ident()
    ticks = 0

    async def ticking() -> None:
        nonlocal ticks
        while True:
            await asyncio.sleep(0.001)
            ticks += 1

    ticker = asyncio.create_task(ticking())
    running = 0
    most = 0
    threads = set()
    original = coarse_glb

    def watched(*args: object) -> bytes:
        nonlocal running, most
        running += 1
        most = max(most, running)
        threads.add(threading.get_ident())
        try:
            return original(*args)  # type: ignore[arg-type]
        finally:
            running -= 1

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr("server.coarse.cache.coarse_glb", watched)
        await asyncio.gather(*(cache.get(path) for path in paths))
    ticker.cancel()
    assert cache.conversions == 4 and most == 1
    assert loop_thread not in threads
    assert ticks > 0  # the loop went on meanwhile


async def test_a_broken_file_is_refused_once_and_remembered(tmp_path: Path) -> None:
    broken = tmp_path / "broken.glb"
    broken.write_bytes(b"glTF" + b"\x02\x00\x00\x00" + b"\xff" * 64)
    cache = CoarseMeshes()
    for _ in range(3):
        with pytest.raises(CoarseError, match="cannot read it as a GLB"):
            await cache.get(broken)
    assert cache.conversions == 1


async def test_the_least_recently_used_are_forgotten_beyond_the_capacity(tmp_path: Path) -> None:
    names = ["L1", "L2", "L4"]
    paths = [tmp_path / f"{name}.glb" for name in names]
    for name, path in zip(names, paths, strict=True):
        shutil.copy(ASSETS / "kin12" / f"{name}.glb", path)
    cache = CoarseMeshes(capacity=2)
    for path in (paths[0], paths[1], paths[0], paths[2]):  # L2 is the least recently used
        await cache.get(path)
    assert cache.conversions == 3
    await cache.get(paths[0])
    assert cache.conversions == 3  # kept
    await cache.get(paths[1])
    assert cache.conversions == 4  # forgotten, made again
