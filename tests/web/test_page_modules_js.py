"""The page's plain modules under node: roll-pitch-yaw against the server's, the quality governor.

``static/js/rpy.js`` must use seed 004's convention exactly as
``server/kinematics/rpy.py`` does (the TCP readout is compared with /fk), and
``static/js/quality.js`` must step down when slow, up with headroom, and not
oscillate.
"""

from __future__ import annotations

import json
import shutil
import subprocess
from typing import Any

import numpy as np

from server.kinematics import matrix_from_pose7, pose7_from_matrix
from server.kinematics.rpy import matrix_from_rpy, rpy_from_matrix
from tests.web._browser import ROOT

JS = ROOT / "static" / "js"
NODE = shutil.which("node")


def run_node(script: str, data: Any) -> Any:
    """Run an ES-module ``script`` under node with ``data`` as JSON on stdin; its JSON output."""
    assert NODE is not None, "node is missing: apt-get install nodejs"
    done = subprocess.run(
        [NODE, "--input-type=module", "-e", script],
        input=json.dumps(data).encode(),
        capture_output=True,
        timeout=30,
        check=False,
    )
    assert done.returncode == 0, done.stderr.decode()
    return json.loads(done.stdout)


RPY_SCRIPT = """
import { rpyFromQuaternion, quaternionFromRpy } from %s;
let input = '';
for await (const chunk of process.stdin) input += chunk;
const { quaternions, angles } = JSON.parse(input);
process.stdout.write(JSON.stringify({
  rpy: quaternions.map(q => rpyFromQuaternion(...q)),
  q: angles.map(a => quaternionFromRpy(...a)),
}));
"""


def test_rpy_agrees_with_the_servers_convention() -> None:
    rng = np.random.default_rng(4)
    angles = rng.uniform([-np.pi, -np.pi / 2, -np.pi], [np.pi, np.pi / 2, np.pi], (200, 3))
    # Gimbal lock both ways, and the identity.
    angles[:3] = [[0.3, np.pi / 2, 1.1], [-0.4, -np.pi / 2, -2.0], [0.0, 0.0, 0.0]]
    rotations = matrix_from_rpy(angles)
    poses = np.zeros((len(angles), 4, 4))
    poses[:, :3, :3], poses[:, 3, 3] = rotations, 1.0
    quaternions = pose7_from_matrix(poses)[:, 3:]
    out = run_node(
        RPY_SCRIPT % json.dumps((JS / "rpy.js").as_uri()),
        {"quaternions": quaternions.tolist(), "angles": angles.tolist()},
    )
    rpy_js = np.array(out["rpy"])
    np.testing.assert_allclose(rpy_js, rpy_from_matrix(rotations), atol=1e-7)
    # And back: the quaternion of the angles is the same rotation.
    pose7 = np.concatenate([np.zeros((len(angles), 3)), np.array(out["q"])], axis=1)
    np.testing.assert_allclose(matrix_from_pose7(pose7)[:, :3, :3], rotations, atol=1e-12)


QUALITY_SCRIPT = """
import { LEVELS, Quality } from %s;
let input = '';
for await (const chunk of process.stdin) input += chunk;
const { phases, pin, start } = JSON.parse(input);
const applied = [];
const quality = new Quality((settings) => applied.push(settings), 2, start);
if (pin !== null) quality.setMode(pin);
// Each phase: [seconds, frames per second] (or a list: the rate at each level).
let t = 0;
const levels = [];
for (const [seconds, fps] of phases) {
  const end = t + seconds * 1000;
  while (t < end) {
    t += 1000 / (Array.isArray(fps) ? fps[quality.level] : fps);
    quality.tick(t);
  }
  levels.push(quality.level);
}
process.stdout.write(JSON.stringify({ levels, applied, count: LEVELS.length,
  changes: quality.changes }));
"""


def governor(
    phases: list[tuple[float, Any]], pin: int | None = None, start: int = 0
) -> dict[str, Any]:
    script = QUALITY_SCRIPT % json.dumps((JS / "quality.js").as_uri())
    result: dict[str, Any] = run_node(script, {"phases": phases, "pin": pin, "start": start})
    return result


def test_quality_steps_down_when_slow_and_up_with_headroom_without_oscillating() -> None:
    # 40 frames/s at every level (short of a 50 Hz stream): one step per 3 s (2 s window +
    # 1 s settling).
    slow = governor([(3.5, 40), (3.1, 40), (60, 40)])
    assert slow["levels"][:2] == [1, 2]
    assert slow["levels"][-1] == slow["count"] - 1  # all the way down, and it stays
    assert slow["applied"][0] == {
        "shadows": False,
        "antialias": True,
        "environment": True,
        "simpleMaterials": False,
        "pixelRatio": 2,
    }
    # Far too slow (under half of 45) skips a level.
    assert governor([(3.5, 20)])["levels"] == [2]
    # Slow at full quality, then plenty of headroom: back up, but not into the level that
    # proved too slow until its back-off has passed.
    back = governor([(3.5, 30), (20, 60), (40, 60)])
    assert back["levels"] == [1, 1, 0]
    # Full quality runs at 30 frames/s, the next level at 60: it tries full quality again
    # ever more rarely (back-off 30 s, 60 s, 120 s, ...), instead of flipping every few seconds.
    flapping = governor([(300, [30, 60, 60, 60, 60, 60])])
    assert flapping["levels"] == [1]
    assert 3 <= flapping["changes"] <= 9, flapping


def test_a_software_start_at_the_lowest_level_tries_a_better_one_only_after_30_s() -> None:
    # Headroom from the start (60 frames/s at the lowest level, 40 at the one above).
    rates = [60, 60, 60, 60, 40, 60]
    assert governor([(29, rates)], start=5)["changes"] == 0  # no try for 30 s
    later = governor([(49, rates)], start=5)
    assert later["levels"] == [5] and later["changes"] == 2  # tried after it, too slow, back


def test_a_pinned_level_stays_whatever_the_frame_rate() -> None:
    pinned = governor([(10, 5), (20, 60)], pin=0)
    assert pinned["levels"] == [0, 0] and pinned["changes"] == 0
    lowest = governor([(20, 60)], pin=5)
    assert lowest["levels"] == [5] and lowest["applied"][-1]["simpleMaterials"] is True
