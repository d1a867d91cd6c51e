"""Source kinds: a protocol is one opener; every kind shares the path after a sample arrived."""

from __future__ import annotations

import asyncio
import dataclasses
import math
from collections.abc import Callable
from pathlib import Path

import orjson
import pytest

from server.cell import Robot, Source, load_cell
from server.cell.load import CellError
from server.runtime import Runtime, SourceDefaults, kinds
from server.runtime.kinds import Opened
from server.sources import Sample, SourceError

# A planar arm: standard DH, two revolute joints, 300 mm and 200 mm links, no offsets or twists.
CELL = """
[[source]]
name = "line1"
{type_line}

[[robot]]
name = "planar"
source = "line1"
kinematics = {{ type = "dh", d = [0.0, 0.0], a = [300.0, 200.0], alpha_deg = [0.0, 0.0] }}
joints = [
    {{ node = "ns=2;s=Arm.J1", unit = "deg" }},
    {{ node = "ns=2;s=Arm.J2", unit = "deg" }},
]
"""
SENT_DEG = (30.0, 45.0)


def cell_file(folder: Path, type_line: str = "") -> Path:
    path = folder / "cell.toml"
    path.write_text(CELL.format(type_line=type_line))
    return path


class ScriptedConnector:
    """A protocol client of a kind the acquisition has never seen: samples on demand."""

    def __init__(self) -> None:
        self.warning: str | None = "scripted: not a real controller"
        self.device: str | None = "robot mode RUNNING"
        self.halted: str | None = "protective stop"
        self.followed: list[str] = []
        self.moves: list[tuple[str, list[float]]] = []
        self.closed = False
        self.deliver: Callable[[Sample], None] | None = None
        self.fail_with: str | None = None

    async def follow(
        self, nodes: list[str], period_s: float, deliver: Callable[[Sample], None]
    ) -> None:
        self.followed = list(nodes)
        if self.fail_with is not None:
            raise SourceError(self.fail_with)
        self.deliver = deliver
        await asyncio.Event().wait()  # until cancelled

    async def move(self, command_node: str, values: list[float]) -> None:
        self.moves.append((command_node, values))

    async def close(self) -> None:
        self.closed = True


async def wait_for(condition: Callable[[], object], timeout_s: float = 5.0) -> None:
    async with asyncio.timeout(timeout_s):
        while not condition():
            await asyncio.sleep(0.01)


@pytest.fixture
def scripted(monkeypatch: pytest.MonkeyPatch) -> ScriptedConnector:
    """A kind named ``scripted`` whose sources connect to one ScriptedConnector."""
    connector = ScriptedConnector()

    async def open_scripted(
        config: Source, robots: list[Robot], defaults: SourceDefaults
    ) -> Opened:
        return Opened(connector, f"scripted://{config.name}")

    monkeypatch.setitem(kinds.OPENERS, "scripted", open_scripted)
    return connector


def as_scripted(path: Path) -> object:
    cell = load_cell(path)
    source = dataclasses.replace(cell.sources[0], type="scripted", url="scripted://line1")
    return dataclasses.replace(cell, sources=(source,))


def test_a_source_without_type_and_one_with_type_ctrlx_load_alike(tmp_path: Path) -> None:
    plain = load_cell(cell_file(tmp_path)).sources[0]
    (tmp_path / "typed").mkdir()
    typed = load_cell(cell_file(tmp_path / "typed", 'type = "ctrlx"')).sources[0]
    assert plain.type == typed.type == "ctrlx"
    assert plain.options == typed.options


def test_an_unknown_source_type_is_named_with_the_choices(tmp_path: Path) -> None:
    with pytest.raises(CellError) as caught:
        load_cell(cell_file(tmp_path, 'type = "ctrlz"'))
    [(key, reason)] = caught.value.problems
    assert key == 'source[0] "line1".type'
    assert "ctrlx" in reason and "'ctrlz'" in reason and "did you mean 'ctrlx'" in reason


async def test_a_new_kind_streams_poses_through_the_shared_path(
    tmp_path: Path, scripted: ScriptedConnector
) -> None:
    cell = as_scripted(cell_file(tmp_path))
    runtime = await Runtime.start(cell)  # type: ignore[arg-type]
    sent: list[str] = []
    runtime.hub.join(protocol=1, send_now=lambda m: sent.append(m.payload) or True)  # type: ignore[arg-type, func-returns-value]
    try:
        await wait_for(lambda: scripted.deliver is not None)
        assert sorted(scripted.followed) == ["ns=2;s=Arm.J1", "ns=2;s=Arm.J2"]
        assert scripted.deliver is not None
        scripted.deliver(
            Sample(1_700_000_000.0, dict(zip(scripted.followed, SENT_DEG, strict=True)))
        )
        frames = []

        def framed() -> bool:
            frames.extend(
                orjson.loads(text)
                for payload in sent
                if isinstance(payload, tuple)
                for text in payload
            )
            sent.clear()
            return bool(frames)

        await wait_for(framed)
        frame = frames[-1]
        assert frame["ok"] and frame["robot"] == "planar"
        q1, q2 = (math.radians(d) for d in SENT_DEG)
        # The planar two-link arm's forward kinematics, written out: x = a1 cos q1 + a2 cos(q1+q2).
        expected = (
            0.3 * math.cos(q1) + 0.2 * math.cos(q1 + q2),
            0.3 * math.sin(q1) + 0.2 * math.sin(q1 + q2),
            0.0,
        )
        assert frame["tcp"][:3] == pytest.approx(expected, abs=1e-12)
        assert frame["joints"] == pytest.approx([q1, q2], abs=1e-15)

        health = runtime.healths()[0]
        assert health.url == "scripted://line1" and health.current_state() == "connected"
        runtime.sources["line1"].acquisition.publish_status()
        status = health.status()
        assert status.device == "robot mode RUNNING"
        assert status.halted == "protective stop"
        assert status.warning == "scripted: not a real controller"
        kept = runtime.history.sources["line1"]
        assert len(kept.ring) == 1  # the timeline and recordings see the sample too
    finally:
        await runtime.stop()
    assert scripted.closed


async def test_a_failing_kind_shows_its_error_and_is_followed_again(
    tmp_path: Path, scripted: ScriptedConnector
) -> None:
    scripted.fail_with = "scripted://line1: BadUserAccessDenied"
    runtime = await Runtime.start(as_scripted(cell_file(tmp_path)))  # type: ignore[arg-type]
    try:
        health = runtime.healths()[0]
        await wait_for(lambda: health.current_state() == "error")
        assert health.status().error == "scripted://line1: BadUserAccessDenied"
        failures = runtime.sources["line1"].acquisition.failures
        await wait_for(lambda: runtime.sources["line1"].acquisition.failures > failures)
    finally:
        await runtime.stop()


async def test_moves_reach_the_kinds_connector_in_node_units(
    tmp_path: Path, scripted: ScriptedConnector
) -> None:
    runtime = await Runtime.start(as_scripted(cell_file(tmp_path)))  # type: ignore[arg-type]
    try:
        robot = runtime.robots[0]
        runtime.defaults = dataclasses.replace(runtime.defaults, allow_commands=True)
        await runtime.move(robot, [math.radians(10.0), math.radians(-20.0)])
        [(node, values)] = scripted.moves
        assert node == "motion/grp/planar/cmd/pos-abs"
        assert values == pytest.approx([10.0, -20.0], abs=1e-12)
    finally:
        await runtime.stop()
