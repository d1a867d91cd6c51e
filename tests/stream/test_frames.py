"""Protocol 2's binary frames: encoded once per sample, decoded back to the same values."""

from __future__ import annotations

import dataclasses
import struct
import time

import numpy as np
import orjson
import pytest

from server.kinematics import Type12
from server.protocol import Frame, decode_frames
from server.stream.frames import (
    MAX_ERROR_BYTES,
    RobotFrame,
    compute_frame,
    encode_binary,
    encode_json,
)
from server.stream.types import RobotSample
from tests.conftest import demo_cell


def frames_for(
    values: list[np.ndarray | None], errors: list[str | None]
) -> list[tuple[int, RobotFrame]]:
    robots = demo_cell().robots
    out = []
    for index, (robot, q, error) in enumerate(zip(robots, values, errors, strict=True)):
        sample = RobotSample(seq=7, t_source=time.time(), values=q, error=error)
        out.append((index, compute_frame(robot, sample)))
    return out


def test_round_trip_of_every_field() -> None:
    frames = frames_for(
        [np.array([10.0, -20.0]), np.full(7, 15.0), None],
        [None, None, "404 DL_INVALID_ADDRESS: nœud «pos_turn» introuvable"],
    )
    data = encode_binary(frames, seq=2**32 + 5, t_source=1795268843.57, t_sent=1795268843.58)
    decoded = decode_frames(data)
    assert (decoded.seq, decoded.t_source, decoded.t_sent) == (5, 1795268843.57, 1795268843.58)
    assert [r.robot_index for r in decoded.robots] == [0, 1, 2]
    for (_, frame), got in zip(frames, decoded.robots, strict=True):
        assert got.ok == frame.ok and got.error == frame.error
        if frame.joints is None:
            assert got.joints.size == 0
        else:
            np.testing.assert_allclose(got.joints, frame.joints, rtol=1e-6, atol=1e-7)
        if frame.ok:
            np.testing.assert_allclose(got.links, frame.links, rtol=1e-6, atol=1e-6)
            np.testing.assert_allclose(got.tcp, frame.tcp, rtol=1e-6, atol=1e-6)
        else:
            assert got.links.shape == (0, 7) and not got.tcp.any()


def test_unreachable_postures_carry_joints_but_no_links() -> None:
    kin12 = demo_cell().robots[0]
    # With L4 far too short the bar cannot close the loop at any angle.
    broken = dataclasses.replace(kin12, kinematics=Type12(l4=0.01))
    sample = RobotSample(seq=1, t_source=0.0, values=np.array([10.0, 20.0]))
    assert compute_frame(kin12, sample).ok
    frame = compute_frame(broken, sample)
    (got,) = decode_frames(encode_binary([(0, frame)], 1, 0.0, 0.0)).robots
    assert not got.ok and got.error is not None and got.error.startswith("unreachable posture")
    assert got.joints.size == 2 and got.links.size == 0


def test_long_errors_are_cut_on_a_character_boundary() -> None:
    sample = RobotSample(seq=1, t_source=0.0, values=None, error="é" * 2000)
    frame = compute_frame(demo_cell().robots[0], sample)
    (got,) = decode_frames(encode_binary([(0, frame)], 1, 0.0, 0.0)).robots
    assert got.error is not None and len(got.error.encode()) <= MAX_ERROR_BYTES
    assert set(got.error) == {"é"}


def test_size_is_40_bytes_per_link_on_the_wire_for_the_demo_cell() -> None:
    frames = frames_for([np.zeros(2), np.zeros(7), np.zeros(2)], [None, None, None])
    links = sum(len(f.links) for _, f in frames)
    wire = len(encode_binary(frames, 1, 0.0, 0.0)) + 4  # WebSocket header of a 126..65535 payload
    assert links == 15 and wire / links <= 42


def test_protocol_1_frames_match_their_model() -> None:
    (_, frame), *_ = frames_for([np.array([10.0, -20.0]), None, None], [None, "x", "y"])
    message = orjson.loads(encode_json(frame, t_sent=1.0))
    Frame.model_validate(message)
    assert message["robot"] == "kin12" and message["ok"] is True


@pytest.mark.parametrize("bad", [b"", b"\x02\x02" + bytes(22), b"\x01\x02\x01\x00" + bytes(20)])
def test_decoding_refuses_what_is_not_a_frames_message(bad: bytes) -> None:
    with pytest.raises((ValueError, struct.error)):
        decode_frames(bad)


def test_setpoints_travel_beside_the_actual_pose_in_both_protocols() -> None:
    kin12, iiwa, _ = demo_cell().robots
    q, q_set = np.array([5.0, 40.0, -10.0, -60.0, 20.0, 30.0, 0.0]), np.full(7, 20.0)
    frame = compute_frame(iiwa, RobotSample(1, 1.7e9, q, setpoints=q_set))
    alone = compute_frame(iiwa, RobotSample(1, 1.7e9, q_set))
    assert frame.setpoint is not None
    # The batch of two is the same as two separate computations.
    np.testing.assert_allclose(frame.setpoint.links, alone.links, atol=1e-12)
    np.testing.assert_allclose(frame.setpoint.tcp, alone.tcp, atol=1e-12)
    np.testing.assert_allclose(frame.links, compute_frame(iiwa, RobotSample(1, 1.7e9, q)).links)
    got = decode_frames(encode_binary([(1, frame)], 1, 1.7e9, 1.7e9)).robots[0]
    assert got.ok and got.setpoint is not None
    np.testing.assert_allclose(got.setpoint.joints, np.radians(q_set), rtol=1e-6)
    np.testing.assert_allclose(got.setpoint.links, alone.links, atol=1e-6)
    np.testing.assert_allclose(got.setpoint.tcp, alone.tcp, atol=1e-6)
    message = Frame.model_validate(orjson.loads(encode_json(frame, 1.7e9)))
    assert message.setpoint is not None
    assert message.setpoint.joints == pytest.approx(np.radians(q_set).tolist())
    # An unreachable setpoint costs the ghost, never the actual pose.
    bad = compute_frame(
        kin12, RobotSample(1, 1.7e9, np.zeros(2), setpoints=np.array([90.0, -180.0]))
    )
    assert bad.ok and bad.setpoint is None


def test_robots_without_setpoints_cost_nothing_extra() -> None:
    frames = frames_for([np.zeros(2), np.zeros(7), np.zeros(2)], [None, None, None])
    without = encode_binary(frames, 1, 1.7e9, 1.7e9)
    robots = demo_cell().robots
    with_setpoint = [
        (0, compute_frame(robots[0], RobotSample(7, 1.7e9, np.zeros(2), setpoints=np.ones(2)))),
        *frames[1:],
    ]
    data = encode_binary(with_setpoint, 1, 1.7e9, 1.7e9)
    # Exactly one robot's joints, links and TCP more: nothing for the other two.
    extra = 4 * (2 + 7 * len(robots[0].link_names) + 7)
    assert len(data) == len(without) + extra
    assert "setpoint" not in orjson.loads(encode_json(frames[1][1], 1.7e9))
