"""The history's memory is fixed up front, and it holds exactly the newest samples."""

from __future__ import annotations

import math
import tracemalloc

import numpy as np

from server.ctrlx import DataLayerError, Sample
from server.history import History, SampleRing

NODES = ("a", "b", "c")


def sample(t: float, a: float | Exception = 1.0) -> Sample:
    return Sample(t, {"a": a, "b": 2.0 * t, "c": -t})


def test_memory_stays_flat_over_a_run_longer_than_the_history() -> None:
    history = History(seconds=2.0)
    source = history.source("demo", NODES, period_s=0.02)
    capacity = source.ring.capacity
    assert capacity == math.ceil(2.0 / 0.02 * 1.25)
    for k in range(capacity):  # fill once: the arrays exist already, nothing grows after
        source.sample(k, sample(k * 0.02))
    before = history.nbytes
    tracemalloc.start()
    try:
        start, _ = tracemalloc.get_traced_memory()
        for k in range(capacity, 10 * capacity):  # 25 s of samples into 2 s of history
            source.sample(k, sample(k * 0.02))
        end, _ = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert end - start < 10_000, f"{end - start} bytes kept by {9 * capacity} samples"
    assert history.nbytes == before
    assert len(source.ring) == capacity == history.samples
    rows = source.ring.rows(0)
    assert rows.seq.tolist() == list(range(9 * capacity, 10 * capacity))
    np.testing.assert_array_equal(rows.values[:, 1], 2.0 * rows.t)


def test_unreadable_nodes_are_nan_and_windows_find_their_times_across_the_wrap() -> None:
    ring_history = History(seconds=1.0)
    source = ring_history.source("demo", NODES, period_s=0.1)  # at least 16 samples
    for k in range(30):
        value: float | Exception = DataLayerError("404") if k == 25 else 1.0
        source.sample(k, sample(float(k), value))
    ring = source.ring
    assert ring.capacity == 16 and ring.span() == (14.0, 29.0)
    rows = ring.between(20.0, 26.5)
    assert rows.t.tolist() == [20.0, 21.0, 22.0, 23.0, 24.0, 25.0, 26.0]
    assert math.isnan(rows.values[5, 0]) and rows.values[4, 0] == 1.0
    assert len(ring.between(40.0, 50.0)) == 0 and len(ring.between(0.0, 13.9)) == 0


def test_marks_follow_state_changes_only() -> None:
    history = History(seconds=10.0)
    source = history.source("demo", NODES, period_s=0.02)
    for state, error in [
        ("connecting", None),
        ("connected", None),
        ("connected", None),
        ("stale", "no sample for 0.3 s"),
        ("stale", "no sample for 1.3 s"),
        ("connected", None),
        ("error", "401 Unauthorized"),
    ]:
        source.state(state, error)
    assert [(m.kind, m.text) for m in history.marks.since(0.0)] == [
        ("stale", "no sample for 0.3 s"),
        ("live", "samples again"),
        ("error", "401 Unauthorized"),
    ]


def test_a_source_that_reads_other_nodes_gets_a_new_history() -> None:
    history = History(seconds=1.0)
    first = history.source("demo", NODES, 0.02)
    assert history.source("demo", reversed(NODES), 0.02) is first
    assert history.source("demo", ("a", "x"), 0.02) is not first
    history.keep_only([])
    assert history.sources == {} and history.nbytes == 0


def test_write_many_keeps_the_newest() -> None:
    ring = SampleRing(("a",), 4)
    ring.write_many(np.arange(10), np.arange(10.0), np.arange(10.0).reshape(10, 1))
    assert ring.rows(0).t.tolist() == [6.0, 7.0, 8.0, 9.0] and ring.count == 10


async def test_a_reload_is_marked_and_keeps_a_source_that_reads_the_same_nodes() -> None:
    from server.runtime import Runtime
    from tests.conftest import demo_cell

    runtime = await Runtime.start(demo_cell())
    try:
        kept = runtime.history.sources["demo"]
        assert len(runtime.history.marks) == 0
        await runtime.apply(demo_cell())
        assert [m.kind for m in runtime.history.marks.since(0.0)] == ["reload"]
        assert runtime.history.sources["demo"] is kept
    finally:
        await runtime.stop()
