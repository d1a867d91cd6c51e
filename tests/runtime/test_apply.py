"""A new cell that cannot start leaves the running one as it was: its sources never stop.

Two embedded mocks (real servers, read over loopback sockets) stream; the new
cell changes one source and adds one whose opener raises what a broken file
raised before (an ``OverflowError`` from a replay's 2^70 sample counter, a
``MemoryError`` from a chunk claiming 2^62 bytes). The opener is the one
fault injected; everything else is the real start-up path.
"""

from __future__ import annotations

import socket
from pathlib import Path
from urllib.parse import urlsplit

import pytest

from server.cell import Cell, Robot, Source, load_cell
from server.runtime import Runtime, SourceDefaults, kinds
from server.runtime.kinds import Opened
from tests.conftest import wait_until
from tests.e2e.test_cells import cell_text


def cell(folder: Path, line2_period_ms: int, bad: bool) -> Cell:
    """line1 and line2 (embedded mocks), one arm each; with ``bad``, a third source."""
    sources = f"""
    [[source]]
    name = "line1"

    [[source]]
    name = "line2"
    period_ms = {line2_period_ms}
    """
    if bad:
        sources += '\n[[source]]\nname = "bad"\n'
    arms = [("a", "line1", 0.0), ("b", "line2", 500.0), *([("c", "bad", 1000.0)] if bad else [])]
    path = folder / "cell.toml"
    path.write_text(cell_text(sources, *arms))
    return load_cell(path)


def answers(url: str) -> bool:
    """Whether something listens at ``url``'s port."""
    parts = urlsplit(url)
    try:
        with socket.create_connection((parts.hostname, parts.port), timeout=1):
            return True
    except OSError:
        return False


@pytest.mark.parametrize("failure", [OverflowError("Python int too large"), MemoryError()])
async def test_a_cell_that_cannot_start_leaves_the_running_sources_streaming(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, failure: BaseException
) -> None:
    opened: list[Opened] = []
    real = kinds.OPENERS["ctrlx"]

    async def opener(config: Source, robots: list[Robot], defaults: SourceDefaults) -> Opened:
        if config.name == "bad":
            raise failure
        opened.append(await real(config, robots, defaults))
        return opened[-1]

    monkeypatch.setitem(kinds.OPENERS, "ctrlx", opener)
    old = cell(tmp_path, 20, bad=False)
    runtime = await Runtime.start(old)
    try:
        before = dict(runtime.sources)
        await wait_until(lambda: all(s.health.processed > 5 for s in before.values()), 20)
        started = len(opened)

        with pytest.raises(type(failure)):
            await runtime.apply(cell(tmp_path, 10, bad=True))  # line2 changes, bad fails

        # The running cell is untouched: the same sources, still following their mocks.
        assert runtime.sources == before and runtime.cell is old
        assert all(s.task is not None and not s.task.done() for s in before.values())
        counts = {name: s.health.processed for name, s in before.items()}
        await wait_until(
            lambda: all(s.health.processed > counts[n] + 5 for n, s in before.items()), 20
        )
        assert all(answers(s.health.url) for s in before.values())
        assert {n: h.ring.nodes for n, h in runtime.history.sources.items()} == {
            n: s.acquisition.tap.ring.nodes for n, s in before.items() if s.acquisition.tap
        }
        # What the failed start had opened (line2's new mock) is closed again.
        (new_line2,) = opened[started:]
        assert new_line2.mock is not None and not answers(new_line2.url)

        # The old file again: nothing to restart, nothing restarted.
        await runtime.apply(old)
        assert runtime.sources == before and len(opened) == started + 1
        # A good new version then starts as usual.
        await runtime.apply(cell(tmp_path, 10, bad=False))
        assert runtime.sources["line1"] is before["line1"]
        assert runtime.sources["line2"] is not before["line2"]
        old_task = before["line2"].task
        assert old_task is not None and old_task.done(), "the replaced source stopped"
        await wait_until(lambda: runtime.sources["line2"].health.processed > 5, 20)
    finally:
        await runtime.stop()
