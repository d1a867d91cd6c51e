"""Whatever else writes to the cluster's Redis: forged records, forged keys, a flood of moves.

The roles are real processes on a real redis-server (tests/cluster/conftest.py);
the forgeries are published with redis-py, as any client of that Redis could.
Each test checks that viewers keep streaming (against the rate the same viewer
got before, from the same run), what health counts, and memory where the
issue measured it growing.
"""

from __future__ import annotations

import asyncio
import threading
import time

import orjson
import redis

from server.cluster import envelope
from server.cluster.commands import MoveCommand
from server.stream import Message
from tests.cluster._roles import (
    Cluster,
    RedisServer,
    Role,
    Seen,
    all_live,
    holders,
    wait_for,
    watch,
)
from tests.cluster.test_cluster import move

FRAMES = "linkview:frames"
SOURCES = [f"s{i}" for i in range(4)]
MIN_SHARE = 0.33
"""During an attack a viewer keeps at least a third of its quiet rate (as tests/e2e/test_limits)."""


def rate(seen: Seen, seconds: float) -> float:
    """Frames messages per second and source that a viewer got."""
    return len(seen.frames) / seconds / len(SOURCES)


def publish(server: RedisServer, batches: list[bytes], channel: str = FRAMES) -> None:
    """Publish every batch, pipelined (as fast as Redis takes them)."""
    with server.client() as client, client.pipeline(transaction=False) as pipe:
        for k, batch in enumerate(batches, 1):
            pipe.publish(channel, batch)
            if k % 1000 == 0:
                pipe.execute()
        pipe.execute()


def status_record(source: str, **changes: object) -> str:
    """A status record as a worker writes it, with ``changes`` (None: the key left out)."""
    status = {
        "name": source,
        "url": "https://forged.example",
        "mock": True,
        "state": "connected",
        "error": None,
        "warning": None,
        "device": None,
        "last_sample_age_s": 0.01,
        "overloaded": None,
    }
    record: dict[str, object] = {"status": status, "robots": {}, "worker": "forger"}
    for key, value in changes.items():
        if key not in status:
            record[key] = value
        elif value is None:
            del status[key]
        else:
            status[key] = value
    return orjson.dumps(record).decode()


def forged(items: list[tuple[str, str | bytes, int | None]]) -> bytes:
    return envelope.pack((key, Message(payload), protocol) for key, payload, protocol in items)


async def one_of_each(cluster: Cluster) -> tuple[Role, Role]:
    """A worker and a replica, once the replica says every source is live."""
    worker, replica = cluster.worker("w"), cluster.replica("r")
    await wait_for(replica, all_live)
    return worker, replica


async def test_forged_status_records_are_dropped_and_the_replica_streams_on(
    cluster: Cluster, redis_server: RedisServer
) -> None:
    _, replica = await one_of_each(cluster)
    batches = [
        forged([("status:s0", status_record("s0", state=None), None)]),  # no "state"
        forged([("status:s1", status_record("s1", robots=[]), None)]),  # robots a list
        forged([("status:s2", status_record("s2", robots={"m0": {"ok": 1}}), None)]),
        forged([("status:s3", status_record("s3", name="s0"), None)]),  # another source's
        forged([("frames2:s0", b"\x01\x02" + bytes(40), 2)]),  # not a frames message
        forged([("frames1:s0", ("{}",), 1)]),  # type: ignore[list-item]
        b"\xff" * 7,  # not a batch at all
    ]
    publish(redis_server, batches)
    await asyncio.sleep(0.5)
    seen = await watch(replica.base, 3.0)
    assert {i for _, i, _, _ in seen.frames} == {0, 1, 2, 3}, "every source still streams"
    assert rate(seen, 3.0) > 10
    body = await wait_for(replica, lambda b: sum(b["broker"]["refused"].values()) >= 7, 10.0)
    refused = body["broker"]["refused"]
    assert refused.get("record") == 4 and refused.get("frames") == 2 and refused.get("batch") == 1
    assert all(s["url"] != "https://forged.example" for s in body["sources"])
    assert body["broker"]["restarts"] == {}
    # Seven refusals within a minute: one line in the log, with what was refused.
    lines = [line for line in replica.log().splitlines() if "refused" in line]
    assert len(lines) == 1 and "from the message broker" in lines[0], lines


async def test_forged_keys_are_not_kept_and_do_not_greet_new_viewers(
    cluster: Cluster, redis_server: RedisServer
) -> None:
    _, replica = await one_of_each(cluster)
    await watch(replica.base, 1.0)  # one viewer has come and gone: its costs are paid
    before = replica.rss_mib()
    # 200 000 keys of a real source, 10 to a batch (a worker's batch has at most 3 per source).
    payload = b"x" * 16  # small: Redis cuts off a subscriber 32 MB behind
    batches = [forged([(f"k{n}-{k}:s0", payload, None) for k in range(10)]) for n in range(20_000)]
    publish(redis_server, batches)
    body = await wait_for(replica, lambda b: b["broker"]["refused"].get("batch", 0) >= 20_000, 60)
    # In each batch the first three keys are refused one by one, then the batch: a worker
    # sends at most three items of a source in one.
    assert body["broker"]["refused"] == {"key": 60_000, "batch": 20_000}
    grown = replica.rss_mib() - before
    assert grown < 25, f"the replica grew by {grown:.0f} MiB"  # 105 MB kept before the fix
    # A new viewer is greeted with what a worker publishes, nothing forged.
    seen = await watch(replica.base, 2.0)
    assert {i for _, i, _, _ in seen.frames} == {0, 1, 2, 3}
    assert sum(len(data) for _, _, _, data in seen.frames) < 1 << 20


def flood_moves(server: RedisServer, worker: str, count: int) -> None:
    """``count`` well-formed moves of m0 on ``worker``'s command channel, pipelined."""
    command = {"robot": "m0", "joints": [0.1, 0.1], "reply": "linkview:reply:forger-1"}
    with server.client() as client, client.pipeline(transaction=False) as pipe:
        for n in range(count):
            pipe.publish(f"linkview:cmd:{worker}", orjson.dumps({**command, "id": f"f-{n}"}))
            if n % 1000 == 999:
                pipe.execute()
        pipe.execute()


class Answers(threading.Thread):
    """Counts the answers the worker publishes to the forger's reply channel, by status."""

    def __init__(self, server: RedisServer) -> None:
        super().__init__(daemon=True)
        self.client = redis.Redis(host="127.0.0.1", port=server.port, socket_timeout=5)
        self.pubsub = self.client.pubsub(ignore_subscribe_messages=True)
        self.pubsub.subscribe("linkview:reply:forger-1")
        self.statuses: dict[int, int] = {}
        self.done = threading.Event()

    def run(self) -> None:
        while not self.done.is_set():
            message = self.pubsub.get_message(timeout=0.2)
            if message is not None:
                status = int(orjson.loads(message["data"])["status"])
                self.statuses[status] = self.statuses.get(status, 0) + 1

    def stop(self) -> None:
        self.done.set()
        self.join(5)
        self.pubsub.close()
        self.client.close()


async def test_a_flood_of_moves_keeps_the_lease_and_the_viewers(
    cluster: Cluster, redis_server: RedisServer
) -> None:
    worker, replica = await one_of_each(cluster)
    holder = holders(redis_server, SOURCES)["s0"]
    assert holder is not None and f"-{worker.process.pid}-" in holder
    quiet = rate(await watch(replica.base, 3.0), 3.0)
    before = worker.rss_mib()
    answers = Answers(redis_server)
    answers.start()
    seen_holders: set[str | None] = set()
    peak = [before]

    async def keep_watching(until: float) -> None:
        while time.monotonic() < until:
            seen_holders.update(holders(redis_server, SOURCES).values())
            peak[0] = max(peak[0], worker.rss_mib())
            await asyncio.sleep(0.1)

    try:
        start = time.monotonic()
        flooding = asyncio.create_task(asyncio.to_thread(flood_moves, redis_server, holder, 30_000))
        watching = asyncio.create_task(keep_watching(start + 8.0))
        during = await watch(replica.base, 8.0)
        await flooding
        await watching
    finally:
        answers.stop()
    assert seen_holders == {holder}, f"the lease changed hands: {seen_holders}"
    assert rate(during, 8.0) >= MIN_SHARE * quiet, f"{rate(during, 8.0):.1f} against {quiet:.1f}"
    assert peak[0] - before < 50, f"the worker grew by {peak[0] - before:.0f} MiB"
    # Most were refused at once, a few (10 a second, 2 at once) moved the robot.
    assert answers.statuses.get(429, 0) > 0 and answers.statuses.get(202, 0) >= 1
    assert answers.statuses.get(202, 0) <= 10 + 10 * 8 + 2
    # The worker still takes a replica's move, once it has read the flood (on a busy machine
    # that may take longer than the replica waits for an answer: 504 meanwhile).
    async with asyncio.timeout(60):
        while (answer := await move(replica, "m1", [0.2, -0.1]))[0] == 504:
            await asyncio.sleep(0.5)
    assert answer[0] == 202, (answer, worker.log()[-2000:])
    assert "moves: refused" in worker.log()


async def test_a_worker_that_does_not_answer_is_a_504_and_gets_the_move_as_workers_take_it(
    cluster: Cluster, redis_server: RedisServer
) -> None:
    replica = cluster.replica("r")  # no worker: this test plays one that never answers
    await wait_for(replica, lambda b: b["broker"]["state"] == "connected")
    with redis_server.client() as client:
        client.set("linkview:lease:s0", b"acquire-mute-1", ex=60)
        pubsub = client.pubsub(ignore_subscribe_messages=True)
        pubsub.subscribe("linkview:cmd:acquire-mute-1")
        status, body = await move(replica, "m0", [0.1, -0.1])
        message = None
        for _ in range(10):  # the first may be the subscription's confirmation
            message = message or pubsub.get_message(timeout=0.5)
        pubsub.close()
    assert status == 504 and "did not answer" in str(body["detail"])
    assert message is not None
    command = MoveCommand.model_validate_json(message["data"])  # what a worker takes
    assert (command.robot, command.joints) == ("m0", [0.1, -0.1])
