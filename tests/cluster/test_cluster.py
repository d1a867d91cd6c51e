"""A cluster on loopback: a real redis-server, acquisition workers and web replicas as processes.

Bounds here are behavioural and generous (a loaded 2-core machine runs them);
the measured takeover gap is a figure of bench/cluster.py.
"""

from __future__ import annotations

import asyncio
import json
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import aiohttp
import numpy as np

from tests.cluster._roles import (
    START_TIMEOUT_S,
    Cluster,
    RedisServer,
    Role,
    Seen,
    all_live,
    health_of,
    holders,
    wait_for,
    watch,
)
from tests.conftest import free_port

SOURCES = [f"s{i}" for i in range(4)]
SETTLED_FRAMES = 20
"""Frames of each source looked at, at least, before the outage and after it."""
TAKEOVER_BOUND_S = 5.0
"""The issue asks for 2 s; this bound leaves room for a loaded test machine."""


async def balanced(
    server: RedisServer, workers: int, timeout_s: float = START_TIMEOUT_S
) -> dict[str, str]:
    """Wait until every source is held and each of ``workers`` holds its share; the holders."""
    async with asyncio.timeout(timeout_s):
        while True:
            held = holders(server, SOURCES)
            counts = Counter(held.values())
            if None not in counts and len(counts) == workers and max(counts.values()) <= 2:
                return {s: str(h) for s, h in held.items()}
            await asyncio.sleep(0.2)


async def poll(url: str, ok: Callable[[str], bool], timeout_s: float = START_TIMEOUT_S) -> None:
    """GET ``url`` until ``ok(body)`` holds; time out after ``timeout_s``."""
    async with aiohttp.ClientSession() as http, asyncio.timeout(timeout_s):
        while True:
            async with http.get(url) as resp:
                if ok(await resp.text()):
                    return
            await asyncio.sleep(0.2)


async def frames_dropped(replica: Role) -> float:
    """Messages the replica skipped for slow viewers so far (its /metrics)."""
    async with aiohttp.ClientSession() as http, http.get(f"{replica.base}/metrics") as resp:
        text = await resp.text()
    (line,) = [row for row in text.splitlines() if row.startswith("linkview_frames_dropped_total")]
    return float(line.rsplit(" ", 1)[1])


def worker_of(role: Role, held: dict[str, str]) -> list[str]:
    """The sources ``role`` (a worker process) holds: its id names its pid."""
    return [s for s, h in held.items() if f"-{role.process.pid}-" in h]


async def move(replica: Role, robot: str, joints: list[float]) -> tuple[int, dict[str, object]]:
    url = f"{replica.base}/api/robots/{robot}/move"
    async with aiohttp.ClientSession() as http, http.post(url, json={"joints": joints}) as resp:
        body: dict[str, object] = await resp.json()
        return resp.status, body


async def test_every_viewer_on_either_replica_gets_the_same_frames(
    cluster: Cluster, redis_server: RedisServer
) -> None:
    workers = [cluster.worker("w1"), cluster.worker("w2")]
    r1, r2 = cluster.replica("r1"), cluster.replica("r2")
    await wait_for(r1, all_live)
    await wait_for(r2, all_live)
    held = await balanced(redis_server, 2)
    assert sorted(len(worker_of(w, held)) for w in workers) == [2, 2]

    # A replica's metrics come from what the workers publish. Balancing has just handed
    # sources from one worker to the other, so one may be briefly stale: poll, bounded.
    wanted = [f'linkview_source_live{{source="{source}"}} 1.0' for source in SOURCES]
    await poll(r2.base + "/metrics", lambda text: all(line in text for line in wanted))
    # The newest raw joint values travel with the workers' status records (once a second).
    await poll(
        r1.base + "/api/robots",
        lambda text: all(j["value"] is not None for r in json.loads(text) for j in r["joints"]),
    )

    a, b = await asyncio.gather(watch(r1.base, 3.0), watch(r2.base, 3.0))
    assert a.hello == b.hello, "replicas must greet alike (same session, same robots)"
    on_a = {(i, seq): data for _, i, seq, data in a.frames}
    on_b = {(i, seq): data for _, i, seq, data in b.frames}
    common = on_a.keys() & on_b.keys()
    assert {i for i, _ in common} == {0, 1, 2, 3}, "every source reaches both replicas"
    assert len(common) >= 0.5 * min(len(on_a), len(on_b))
    assert all(on_a[k] == on_b[k] for k in common), "the same seq must be the same bytes"

    # A viewer that left r1 and comes back through r2 carries on where it was.
    last = {i: max(seq for (j, seq) in on_a if j == i) for i in range(4)}
    again = await watch(r2.base, 1.5)
    assert again.hello == a.hello
    for i in range(4):
        assert max(seq for _, j, seq, _ in again.frames if j == i) > last[i]


async def test_killing_a_worker_moves_its_sources_to_the_other(
    cluster: Cluster, redis_server: RedisServer
) -> None:
    victim = cluster.worker("w1")
    replica = cluster.replica("r")
    await wait_for(replica, all_live)
    survivor = cluster.worker("w2")  # joins late: w1 hands half of its sources over
    held = await balanced(redis_server, 2)
    lost = worker_of(victim, held)
    assert len(lost) == 2 and len(worker_of(survivor, held)) == 2
    indices = [SOURCES.index(s) for s in lost]

    killed_at: list[float] = []

    def resumed(seen: Seen) -> bool:
        return bool(killed_at) and all(
            any(t > killed_at[0] + 0.1 for t in seen.arrivals(i)) for i in indices
        )

    viewer = asyncio.create_task(watch(replica.base, 30.0, resumed))
    await asyncio.sleep(2.0)
    victim.kill()
    killed_at.append(time.monotonic())
    seen = await viewer
    assert resumed(seen), f"frames of {lost} did not resume:\n{survivor.log()}"
    for i in indices:
        arrivals = seen.arrivals(i)
        before = max(t for t in arrivals if t < killed_at[0])
        after = min(t for t in arrivals if t > killed_at[0] + 0.1)
        assert after - before < TAKEOVER_BOUND_S, f"source {SOURCES[i]}: {after - before:.2f} s"
    now = holders(redis_server, SOURCES)
    assert worker_of(survivor, {s: str(h) for s, h in now.items()}) == SOURCES
    body = await wait_for(replica, all_live)
    assert set(body["broker"]["workers"].values()) == {now["s0"]}


async def test_redis_restarting_loses_only_the_frames_of_those_seconds(
    cluster: Cluster, redis_server: RedisServer
) -> None:
    workers = [cluster.worker("w1"), cluster.worker("w2")]
    replicas = [cluster.replica("r1"), cluster.replica("r2")]
    for replica in replicas:
        await wait_for(replica, all_live)
    await balanced(redis_server, 2)
    back: list[float] = []
    settled: list[float] = []

    streaming = asyncio.Event()

    def resumed(seen: Seen) -> bool:
        """Every source streams again, and enough frames of each came after the cluster
        settled (``streaming``: as many came before the outage)."""
        # One more than is checked before the outage: the greeting may be left out there.
        if all(len(seen.arrivals(i)) > SETTLED_FRAMES for i in range(4)):
            streaming.set()
        return bool(settled) and all(
            sum(t > settled[0] for t in seen.arrivals(i)) >= SETTLED_FRAMES for i in range(4)
        )

    dropped_before = await frames_dropped(replicas[0])
    viewer = asyncio.create_task(watch(replicas[0].base, 60.0, resumed))
    async with asyncio.timeout(START_TIMEOUT_S):
        await streaming.wait()
    stopped = time.monotonic()
    redis_server.stop()
    for replica in replicas:
        body = await wait_for(replica, lambda b: b["broker"]["state"] == "error")
        code, body = await health_of(replica)
        assert code == 503 and body["status"] == "degraded"
        assert (
            "unreachable" in body["broker"]["error"] and redis_server.url in body["broker"]["error"]
        )
        for source in body["sources"]:
            assert source["state"] == "error" and "message broker" in source["error"]
    await asyncio.sleep(1.0)
    redis_server.start()
    back.append(time.monotonic())
    for replica in replicas:
        await wait_for(replica, all_live)
    held = await balanced(redis_server, 2)
    settled.append(time.monotonic())
    seen = await viewer  # the same connection throughout: the viewer lost only frames
    assert resumed(seen)
    # Only those seconds: each source's frames before the outage and after the cluster
    # settled follow one another sample by sample (a source taken over in between may count
    # anew), but for what the replica itself reports skipping for a slow viewer.
    skipped = await frames_dropped(replicas[0]) - dropped_before
    missing = 0
    for i in range(4):
        for before, part in ((True, lambda t: t < stopped), (False, lambda t: t > settled[0])):
            seqs = [seq for t, j, seq, _ in seen.frames if j == i and part(t)]
            if before and len(seqs) > 1 and seqs[1] < seqs[0]:
                # The greeting: the newest frame the replica held when the viewer came, which
                # may be the previous holder's if the balance moved the source just before.
                seqs = seqs[1:]
            steps = np.diff(seqs)
            back_steps = [(k, int(step)) for k, step in enumerate(steps) if step < 1]
            assert len(seqs) >= SETTLED_FRAMES and not back_steps, (i, len(seqs), back_steps)
            missing += int((steps - 1).sum())
    assert missing <= skipped, (missing, skipped)
    assert any(s["state"] == "error" and "message broker" in s["error"] for s in seen.statuses)
    assert sorted(len(worker_of(w, held)) for w in workers) == [2, 2]
    for worker in workers:
        log = worker.log()
        assert "unreachable" in log and "reached" in log.split("unreachable", 1)[1]


async def test_roles_started_without_redis_say_so_and_keep_trying(
    tmp_path: Path, cell_file: Path
) -> None:
    server = RedisServer(tmp_path / "redis", free_port())  # not started yet
    roles = Cluster(tmp_path, server.url, cell_file)
    try:
        worker, replica = roles.worker(), roles.replica()
        body = await wait_for(replica, lambda b: True)
        code, body = await health_of(replica)
        assert code == 503 and body["broker"]["state"] == "error"
        assert f"message broker {server.url} unreachable" in body["broker"]["error"]
        assert all(f"message broker {server.url}" in s["error"] for s in body["sources"])
        status, answer = await move(replica, "m0", [0.1, 0.1])
        assert status == 503 and "broker" in str(answer["detail"])
        async with asyncio.timeout(START_TIMEOUT_S):
            while worker.log().count("unreachable") < 1:
                await asyncio.sleep(0.1)
        assert f"message broker {server.url} unreachable" in worker.log()
        assert "retrying every" in worker.log()
        await asyncio.sleep(2.0)
        assert worker.process.poll() is None and replica.process.poll() is None
        server.start()
        await wait_for(replica, all_live)
        assert "reached" in worker.log()
    finally:
        roles.close()
        server.stop()


async def test_moves_reach_the_worker_that_holds_the_robot(
    cluster: Cluster, redis_server: RedisServer
) -> None:
    replica = cluster.replica("r")
    body = await wait_for(
        replica, lambda b: all("no acquisition worker" in (s["error"] or "") for s in b["sources"])
    )
    assert body["broker"]["state"] == "connected"
    status, answer = await move(replica, "m2", [0.1, 0.1])
    assert status == 503 and "no acquisition worker" in str(answer["detail"])

    cluster.worker("w1")
    cluster.worker("w2")
    await wait_for(replica, all_live)
    await balanced(redis_server, 2)
    status, answer = await move(replica, "m2", [0.7, 0.1])
    assert status == 422 and "outside the joint limits: a0" in str(answer["detail"])
    target = [0.3, -0.2]
    status, answer = await move(replica, "m2", target)
    assert status == 202, answer

    def arrived(seen: Seen) -> bool:
        last = next((f for f in reversed(seen.json_frames) if f["robot"] == "m2"), None)
        return last is not None and np.allclose(last["joints"], target, atol=1e-6)

    # Protocol 1: the workers encode JSON frames only once a replica asks for them.
    seen = await watch(replica.base, 30.0, arrived, protocol=1)
    assert arrived(seen), seen.json_frames[-1:]
