"""The history's memory grows with use up to a fixed bound, and it holds exactly the newest
samples (checked against a ``collections.deque`` of the same length)."""

from __future__ import annotations

import math
import tracemalloc
from collections import deque

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from server.ctrlx import DataLayerError, Sample
from server.history import History, SampleRing
from server.history.ring import BLOCK_BYTES

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


def test_memory_grows_with_samples_not_with_the_number_of_nodes() -> None:
    # 4 000 six-axis robots on one source, 600 s at 50 Hz: 7.2 GB if held whole.
    nodes = tuple(f"n{i}" for i in range(24_000))
    history = History(seconds=600.0)
    source = history.source("plant", nodes, period_s=0.02)
    full = source.ring.capacity * (len(nodes) + 2) * 8
    assert full > 7e9 and history.nbytes == 0
    row = {n: 1.0 for n in nodes}
    for k in range(100):  # two seconds of samples
        source.sample(k, Sample(k * 0.02, row))
    row_bytes = (len(nodes) + 2) * 8
    # What 100 samples take, and at most one block more, allocated ahead.
    assert 100 * row_bytes <= history.nbytes <= (100 + source.ring.block_rows) * row_bytes
    assert source.ring.block_rows * row_bytes <= max(BLOCK_BYTES, 16 * row_bytes)
    assert len(source.ring.rows(0)) == 100


@given(
    st.integers(min_value=2, max_value=40),
    st.lists(st.integers(min_value=1, max_value=25), min_size=1, max_size=12),
    st.integers(min_value=0, max_value=60),
    st.integers(min_value=0, max_value=60),
)
def test_rows_and_windows_across_blocks_match_a_deque(
    capacity: int, writes: list[int], start: int, length: int
) -> None:
    ring = SampleRing(("a", "b"), capacity)
    ring.block_rows = 3  # many block boundaries in a small ring
    ring._t = [None] * -(-capacity // 3)  # noqa: SLF001 (re-laid out for the small blocks)
    ring._seq, ring._values = list(ring._t), list(ring._t)  # noqa: SLF001
    reference: deque[tuple[int, float, float, float]] = deque(maxlen=capacity)
    k = 0
    for n in writes:  # single writes and batches, as live sources and replays write
        seq = np.arange(k, k + n)
        t = seq * 0.5
        values = np.stack([t, -t], axis=1)
        if n == 1:
            ring.write(k, float(t[0]), values[0].tolist())
        else:
            ring.write_many(seq, t, values)
        pairs = zip(seq.tolist(), t.tolist(), strict=True)
        reference.extend((s, x, x, -x) for s, x in pairs)
        k += n
    rows = ring.rows(0)
    assert rows.seq.tolist() == [r[0] for r in reference]
    assert rows.values.tolist() == [[r[2], r[3]] for r in reference]
    t_from, t_to = start * 0.5, (start + length) * 0.5
    window = ring.between(t_from, t_to)
    assert window.t.tolist() == [r[1] for r in reference if t_from <= r[1] <= t_to]
    assert ring.span() == (reference[0][1], reference[-1][1])
