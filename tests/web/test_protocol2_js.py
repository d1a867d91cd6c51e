"""The page's protocol-2 decoder (static/js/protocol2.js, run by node) agrees with the server's.

Messages are encoded by the server's own encoder (``encode_binary`` over
``compute_frame``) or built by hand, decoded by the JavaScript module under
node and by ``server.protocol.decode_frames``, and every field is compared.
"""

from __future__ import annotations

import base64
import json
import shutil
import struct
import subprocess
from typing import Any

import numpy as np
import pytest

from server.protocol import FRAMES_HEADER, FRAMES_VERSION, ROBOT_HEADER, decode_frames
from server.stream.frames import MAX_ERROR_BYTES, compute_frame, encode_binary
from server.stream.types import RobotSample
from tests.conftest import demo_cell
from tests.web._browser import ROOT

MODULE = ROOT / "static" / "js" / "protocol2.js"
NODE = shutil.which("node")

# Reads base64 messages from stdin (a JSON list), prints one JSON answer per message:
# the decoded message with typed arrays as lists, or {"error": message}.
SCRIPT = """
import { decodeFrames, isFrames } from %s;
let input = '';
for await (const chunk of process.stdin) input += chunk;
const out = JSON.parse(input).map((b64) => {
  const bytes = Buffer.from(b64, 'base64');
  // Copy into a fresh buffer at an odd offset: the decoder must not rely on alignment.
  const backing = new ArrayBuffer(bytes.length + 3);
  const view = new Uint8Array(backing, 3, bytes.length);
  view.set(bytes);
  try {
    const m = decodeFrames(view);
    return { isFrames: isFrames(backing.slice(3)), seq: m.seq, t_source: m.t_source,
      t_sent: m.t_sent, robots: m.robots.map((r) => ({ robot_index: r.robot_index, ok: r.ok,
        joints: Array.from(r.joints), links: Array.from(r.links), tcp: Array.from(r.tcp),
        error: r.error, setpoint: r.setpoint && { joints: Array.from(r.setpoint.joints),
          links: Array.from(r.setpoint.links), tcp: Array.from(r.setpoint.tcp) } })) };
  } catch (err) {
    return { error: String(err.message) };
  }
});
process.stdout.write(JSON.stringify(out));
"""


def decode_in_node(messages: list[bytes]) -> list[dict[str, Any]]:
    """Decode each message with static/js/protocol2.js under node."""
    assert NODE is not None, "node is missing: apt-get install nodejs"
    script = SCRIPT % json.dumps(MODULE.as_uri())
    payload = json.dumps([base64.b64encode(m).decode() for m in messages])
    done = subprocess.run(
        [NODE, "--input-type=module", "-e", script],
        input=payload.encode(),
        capture_output=True,
        timeout=30,
        check=False,
    )
    assert done.returncode == 0, done.stderr.decode()
    result: list[dict[str, Any]] = json.loads(done.stdout)
    return result


def assert_same(data: bytes, js: dict[str, Any]) -> None:
    """Every field of the JS decoding equals the Python decoding of ``data``."""
    py = decode_frames(data)
    assert "error" not in js, js
    assert js["isFrames"] is True
    assert (js["seq"], js["t_source"], js["t_sent"]) == (py.seq, py.t_source, py.t_sent)
    assert len(js["robots"]) == len(py.robots)
    for got, want in zip(js["robots"], py.robots, strict=True):
        assert got["robot_index"] == want.robot_index
        assert got["ok"] is want.ok
        assert got["error"] == want.error
        # float32 values survive JSON exactly as doubles: compare for equality.
        assert got["joints"] == want.joints.astype(np.float64).tolist()
        assert got["links"] == want.links.reshape(-1).astype(np.float64).tolist()
        assert got["tcp"] == want.tcp.astype(np.float64).tolist()
        if want.setpoint is None:
            assert got["setpoint"] is None
        else:
            sp = got["setpoint"]
            assert sp["joints"] == want.setpoint.joints.astype(np.float64).tolist()
            assert sp["links"] == want.setpoint.links.reshape(-1).astype(np.float64).tolist()
            assert sp["tcp"] == want.setpoint.tcp.astype(np.float64).tolist()


def encoded_samples(rng: np.random.Generator, count: int) -> list[bytes]:
    """Messages of the demo cell's three robots at random joints, as the server sends them."""
    cell = demo_cell()
    messages = []
    for seq in range(count):
        frames = []
        for index, robot in enumerate(cell.robots):
            values = rng.uniform(-30.0, 30.0, len(robot.joints))  # degrees, within every limit
            sample = RobotSample(seq=seq, t_source=1.7e9 + seq * 0.02, values=values)
            frames.append((index, compute_frame(robot, sample)))
        messages.append(encode_binary(frames, seq, 1.7e9 + seq * 0.02, 1.7e9 + seq * 0.02 + 3e-3))
    return messages


def test_round_trip_of_the_servers_own_messages() -> None:
    messages = encoded_samples(np.random.default_rng(11), 20)
    decoded = decode_in_node(messages)
    for data, js in zip(messages, decoded, strict=True):
        assert len(js["robots"]) == 3
        assert all(r["ok"] and len(r["links"]) % 7 == 0 and r["links"] for r in js["robots"])
        assert_same(data, js)


def test_errors_in_any_language_and_robots_that_are_not_ok() -> None:
    cell = demo_cell()
    kin12, iiwa, positioner = cell.robots
    text = "404 DL_INVALID_ADDRESS: Ünknöwn ✗"
    failed = RobotSample(seq=7, t_source=1.7e9, values=None, error=text)
    unreachable = RobotSample(seq=7, t_source=1.7e9, values=np.array([90.0, -180.0]))
    good = RobotSample(seq=7, t_source=1.7e9, values=np.zeros(7))
    long = RobotSample(seq=7, t_source=1.7e9, values=None, error="日本語のエラー" * 200)
    frames = [
        (0, compute_frame(kin12, unreachable)),  # ok = 0 with joints (the sample was read)
        (2, compute_frame(positioner, failed)),  # ok = 0, no joints, odd error length
        (1, compute_frame(iiwa, good)),  # floats after an unaligned error
        (2, compute_frame(positioner, long)),  # cut to MAX_ERROR_BYTES on a character boundary
    ]
    data = encode_binary(frames, 2**32 + 5, 1.7e9, 1.7e9 + 0.01)
    (js,) = decode_in_node([data])
    assert_same(data, js)
    first, second, third, fourth = js["robots"]
    assert not first["ok"] and len(first["joints"]) == 2 and first["links"] == []
    assert first["error"].startswith("unreachable posture")
    assert not second["ok"] and second["joints"] == [] and second["tcp"] == [0.0] * 7
    assert second["error"] == text
    assert (
        third["ok"] and len(third["links"]) == 7 * len(iiwa.link_names) and third["error"] is None
    )
    assert 0 < len(fourth["error"].encode()) <= MAX_ERROR_BYTES
    assert js["seq"] == 5  # the wire's seq is 32 bits


def test_hand_built_message_and_an_empty_one() -> None:
    body = ROBOT_HEADER.pack(3, 1, 1, 1, 0) + np.arange(1 + 7 + 7, dtype="<f4").tobytes()
    data = FRAMES_HEADER.pack(1, FRAMES_VERSION, 1, 42, 12.5, 13.25) + body
    empty = FRAMES_HEADER.pack(1, FRAMES_VERSION, 0, 0, 0.0, 0.0)
    js, js_empty = decode_in_node([data, empty])
    assert_same(data, js)
    assert_same(empty, js_empty)
    (robot,) = js["robots"]
    assert robot["joints"] == [0.0] and robot["links"] == list(map(float, range(1, 8)))
    assert robot["tcp"] == list(map(float, range(8, 15)))


BAD = [
    b"",
    FRAMES_HEADER.pack(1, FRAMES_VERSION, 0, 0, 0.0, 0.0)[:23],  # shorter than the header
    FRAMES_HEADER.pack(1, 1, 0, 0, 0.0, 0.0),  # version 1
    FRAMES_HEADER.pack(2, FRAMES_VERSION, 0, 0, 0.0, 0.0),  # another kind
    FRAMES_HEADER.pack(1, FRAMES_VERSION, 0, 0, 0.0, 0.0) + b"\0",  # a byte left over
    FRAMES_HEADER.pack(1, FRAMES_VERSION, 1, 0, 0.0, 0.0)
    + ROBOT_HEADER.pack(0, 1, 2, 0, 0),  # cut off
    FRAMES_HEADER.pack(1, FRAMES_VERSION, 2, 0, 0.0, 0.0)
    + ROBOT_HEADER.pack(0, 0, 0, 0, 0)
    + bytes(28),  # the second robot is missing
]


def test_what_python_refuses_javascript_refuses() -> None:
    for data in BAD:
        with pytest.raises((ValueError, struct.error)):
            decode_frames(data)
    for data, js in zip(BAD, decode_in_node(BAD), strict=True):
        assert "error" in js and js["error"], (data, js)


def test_setpoints_after_an_unaligned_error_and_beside_robots_without() -> None:
    cell = demo_cell()
    kin12, iiwa, positioner = cell.robots
    both = RobotSample(seq=3, t_source=1.7e9, values=np.full(7, 10.0), setpoints=np.full(7, 12.5))
    failed = RobotSample(seq=3, t_source=1.7e9, values=None, error="Ärger", setpoints=np.zeros(2))
    plain = RobotSample(seq=3, t_source=1.7e9, values=np.array([5.0, 7.0]))
    frames = [
        (2, compute_frame(positioner, failed)),  # no poses: no setpoint either
        (1, compute_frame(iiwa, both)),
        (0, compute_frame(kin12, plain)),
    ]
    data = encode_binary(frames, 9, 1.7e9, 1.7e9 + 0.01)
    (js,) = decode_in_node([data])
    assert_same(data, js)
    first, second, third = js["robots"]
    assert first["setpoint"] is None and third["setpoint"] is None
    assert second["setpoint"]["joints"] == pytest.approx([np.radians(12.5)] * 7)
    assert second["setpoint"]["links"] != second["links"]
