"""Robots of one kinematic model are computed together: in one call, with the same results."""

from __future__ import annotations

import asyncio
import dataclasses
import gc
import weakref
from pathlib import Path

import numpy as np

from server.cell import Robot, load_cell
from server.kinematics import Type12
from server.stream.batches import BATCH_WINDOW_S, Pending, SampleBatch, outcomes_of, sample_batch
from server.stream.frames import compute_frame, compute_frames
from server.stream.types import RobotSample

IIWA = (
    '{ type = "dh", convention = "standard", solver = "iiwa", '
    "d = [340.0, 0.0, 400.0, 0.0, 400.0, 0.0, 126.0], a = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], "
    "alpha_deg = [-90.0, 90.0, 90.0, -90.0, -90.0, 90.0, 0.0] }"
)


def arm(name: str, kinematics: str = IIWA, joints: int = 7) -> str:
    nodes = ", ".join(f'{{ node = "{name}/{j}", unit = "deg" }}' for j in range(joints))
    return (
        f'[[robot]]\nname = "{name}"\nsource = "line1"\nkinematics = {kinematics}\n'
        f"joints = [{nodes}]\n"
    )


def cell_robots(tmp_path: Path) -> tuple[Robot, ...]:
    """Three iiwa arms described alike, and a five-bar (Type 12) of another model."""
    text = '[[source]]\nname = "line1"\n' + "".join(arm(n) for n in ("a", "b", "c"))
    text += arm("five_bar", '{ type = "type12" }', joints=2)
    path = tmp_path / "cell.toml"
    path.write_text(text)
    return load_cell(path, env={}, cache_dir=tmp_path / "cache").robots


@dataclasses.dataclass
class CountingKinematics:
    """A model's kinematics that counts its calls (one per batch, not per robot)."""

    inner: object
    calls: int = 0

    def link_poses(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.calls += 1
        return self.inner.link_poses(q)  # type: ignore[attr-defined, no-any-return]


def test_robots_described_alike_share_one_model(tmp_path: Path) -> None:
    a, b, c, five_bar = cell_robots(tmp_path)
    assert a.kinematics is b.kinematics is c.kinematics
    assert five_bar.kinematics is not a.kinematics


def test_a_batch_computes_each_model_once_and_as_each_robot_alone(tmp_path: Path) -> None:
    a, b, c, five_bar = cell_robots(tmp_path)
    counting = CountingKinematics(a.kinematics)
    arms = [dataclasses.replace(r, kinematics=counting) for r in (a, b, c)]  # type: ignore[arg-type]
    rng = np.random.default_rng(3)
    jobs = [
        (arms[0], RobotSample(1, 1.7e9, rng.uniform(-90, 90, 7))),
        (five_bar, RobotSample(1, 1.7e9, np.array([10.0, 20.0]))),
        (arms[1], RobotSample(2, 1.7e9, rng.uniform(-90, 90, 7), setpoints=np.zeros(7))),
        (arms[2], RobotSample(3, 1.7e9, None, error="node not found")),
    ]
    frames = compute_frames(jobs)
    assert counting.calls == 1, "the two arms read (and one setpoint) go through one call"
    assert [f.robot.name for f in frames] == ["a", "five_bar", "b", "c"]
    assert [f.ok for f in frames] == [True, True, True, False]
    assert frames[3].error == "node not found" and frames[3].joints is None
    for (robot, sample), frame in zip(jobs[:3], frames[:3], strict=True):
        alone = compute_frame(robot, sample)
        np.testing.assert_allclose(frame.joints, alone.joints)  # type: ignore[arg-type]
        np.testing.assert_allclose(frame.links, alone.links, atol=1e-12)
        np.testing.assert_allclose(frame.tcp, alone.tcp, atol=1e-12)
    assert frames[2].setpoint is not None
    home = compute_frame(arms[1], RobotSample(2, 1.7e9, np.zeros(7)))
    np.testing.assert_allclose(frames[2].setpoint.links, home.links, atol=1e-12)


def test_an_unreachable_posture_costs_only_its_robot(tmp_path: Path) -> None:
    *_, five_bar = cell_robots(tmp_path)
    short = dataclasses.replace(five_bar, name="short", kinematics=Type12(l4=0.01))
    frames = compute_frames(
        [
            (five_bar, RobotSample(1, 0.0, np.array([10.0, 20.0]))),
            (short, RobotSample(1, 0.0, np.array([10.0, 20.0]))),
        ]
    )
    assert frames[0].ok and len(frames[0].links) == len(five_bar.link_names)
    assert not frames[1].ok and frames[1].error.startswith("unreachable posture")  # type: ignore[union-attr]


def test_a_robot_whose_kinematics_fails_costs_no_other_its_frame(tmp_path: Path) -> None:
    a, b, *_ = cell_robots(tmp_path)
    broken = dataclasses.replace(b, kinematics=None)  # type: ignore[arg-type]
    jobs = [(a, RobotSample(1, 0.0, np.zeros(7))), (broken, RobotSample(1, 0.0, np.zeros(7)))]
    (ok, none), (failed, bug) = outcomes_of(jobs)
    assert ok.ok and none is None
    assert not failed.ok and isinstance(bug, AttributeError) and "AttributeError" in failed.error  # type: ignore[operator]


async def test_samples_of_one_window_are_computed_together_at_its_end(tmp_path: Path) -> None:
    a, b, c, _ = cell_robots(tmp_path)
    batch = SampleBatch()
    got: list[tuple[str, bool, float]] = []

    def done(name: str) -> object:
        return lambda outcomes, share: got.append((name, outcomes[0][0].ok, share))

    for robot in (a, b):
        batch.add(Pending([(robot, RobotSample(1, 0.0, np.zeros(7)))], done(robot.name)))  # type: ignore[arg-type]
    await asyncio.sleep(0)
    assert got == [], "the first sample waits for others"
    batch.add(Pending([(c, RobotSample(1, 0.0, np.zeros(7)))], done(c.name)))  # type: ignore[arg-type]
    await asyncio.sleep(BATCH_WINDOW_S * 5)
    assert [name for name, _, _ in got] == ["a", "b", "c"] and all(ok for _, ok, _ in got)
    assert (batch.batches, batch.sizes) == (1, 3)
    assert all(share > 0 for _, _, share in got)


async def test_a_flushed_batch_is_computed_at_once_and_its_timer_finds_nothing(
    tmp_path: Path,
) -> None:
    a, *_ = cell_robots(tmp_path)
    batch, got = SampleBatch(), []
    batch.add(Pending([(a, RobotSample(1, 0.0, np.zeros(7)))], lambda o, s: got.append(o)))  # type: ignore[arg-type]
    batch.flush()
    assert len(got) == 1 and (batch.batches, batch.sizes) == (1, 1)
    await asyncio.sleep(BATCH_WINDOW_S * 5)  # the window's timer fires on an empty batch
    assert len(got) == 1 and batch.batches == 1


def test_a_finished_event_loop_is_not_kept_alive_by_its_batch() -> None:
    async def use() -> None:
        sample_batch()

    loop = asyncio.new_event_loop()
    loop.run_until_complete(use())
    loop.close()
    gone = weakref.ref(loop)
    del loop
    gc.collect()
    assert gone() is None, "the registry must hold loops weakly, and the batch none at all"
