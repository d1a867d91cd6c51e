"""Calibrating external axes over real sockets, as MotionPlus does, and placing them by it.

The cell's embedded mock drives an LBR iiwa (the measuring robot) and two
axis groups whose bases in the file are wrong (``discover``'s placeholders):
the demo cell's tilting positioner, which really stands at x = 1350 mm, and a
linear rail. The true geometry is written out here by hand, independently of
the server: the turntable turns about +Z through (1.35, 0, 0.55) m at tilt 0;
the rail runs along world +Y from (1.0, -0.05, 0.3) m. The iiwa's TCP is
driven (``/ik``, ``/move``) to a mark on the turntable at three turntable
angles, and to a mark on the rail's carriage at three carriage positions;
each TCP is sampled (``/tcp``) and fitted (``/api/calibrate``); the frame
must be the true one to 1e-9 m and 1e-9 rad, and, applied, it must put each
group's base where the machine really has it.

The worked examples of the MotionPlus Axis Group API document
(``calibrate_rotary_axis``, ``calibrate_linear_axis``) are the other set.
"""

from __future__ import annotations

import asyncio
import math
from pathlib import Path
from typing import Any

import aiohttp
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from server.config import Settings
from tests.commissioning.cells import cell_file as written
from tests.conftest import running_server

ROOT = Path(__file__).resolve().parents[2]
ARM_BASE_MM = (1000.0, -350.0, 0.0)
ARM_YAW_DEG = 30.0
TURN_CENTRE = np.array([1.35, 0.0, 0.55])  # the demo positioner at x = 1350 mm, tilt 0
RAIL_ORIGIN = np.array([1.0, -0.05, 0.3])
RAIL_Z, RAIL_X = np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0])
RADIUS = 0.15
DOWN = [1.0, 0.0, 0.0, 0.0]  # TCP quaternion (x, y, z, w): its +Z pointing down

CELL = f"""
[[source]]
name = "line"

[[robot]]
name = "arm"
source = "line"
base = {{ xyz = {list(ARM_BASE_MM)}, rpy_deg = [0.0, 0.0, {ARM_YAW_DEG}] }}
joints = [
    {{ node = "motion/axs/a1/state/values/actual/pos" }},
    {{ node = "motion/axs/a2/state/values/actual/pos" }},
    {{ node = "motion/axs/a3/state/values/actual/pos" }},
    {{ node = "motion/axs/a4/state/values/actual/pos" }},
    {{ node = "motion/axs/a5/state/values/actual/pos" }},
    {{ node = "motion/axs/a6/state/values/actual/pos" }},
    {{ node = "motion/axs/a7/state/values/actual/pos" }},
]
demo_targets = [[0.0, 20.0, 0.0, -60.0, 0.0, 45.0, 0.0]]

[robot.kinematics]
type = "dh"
solver = "iiwa"
d = [340.0, 0.0, 400.0, 0.0, 400.0, 0.0, 126.0]
a = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
alpha_deg = [-90.0, 90.0, 90.0, -90.0, -90.0, 90.0, 0.0]

[[robot]]
name = "positioner"
source = "line"
# TODO: where the robot stands in the cell (mm, deg); 1000 mm apart for now.
base = {{ xyz = [2000.0, 0.0, 0.0], rpy_deg = [0.0, 0.0, 0.0] }}
joints = [
    {{ node = "motion/axs/pos_tilt/state/values/actual/pos", unit = "deg" }},
    {{ node = "motion/axs/pos_turn/state/values/actual/pos", unit = "deg" }},
]
demo_targets = [[0.0, 0.0]]

[robot.kinematics]
type = "axis_group"

[[robot.kinematics.axes]]
name = "tilt"
pose = {{ xyz = [0.0, 0.0, 450.0], rpy_deg = [0.0, 90.0, 0.0] }}
limits = [-60.0, 60.0]

[[robot.kinematics.axes]]
name = "turn"
parent = "tilt"
pose = {{ xyz = [-100.0, 0.0, 0.0], rpy_deg = [0.0, -90.0, 0.0] }}
limits = [-360.0, 360.0]

[[robot]]
name = "rail"
source = "line"
base = {{ xyz = [3000.0, 0.0, 0.0], rpy_deg = [0.0, 0.0, 0.0] }}
joints = [{{ node = "motion/axs/rail_s/state/values/actual/pos", unit = "mm" }}]
demo_targets = [[0.0]]

[robot.kinematics]
type = "axis_group"
axes = [{{ name = "slide", type = "linear", limits = [0.0, 500.0] }}]
"""


def arm_base() -> np.ndarray:
    """The arm's base in the cell, as the cell above says it (independent of the server)."""
    base = np.eye(4)
    base[:3, :3] = Rotation.from_euler("z", ARM_YAW_DEG, degrees=True).as_matrix()
    base[:3, 3] = np.array(ARM_BASE_MM) / 1000.0
    return base


def in_arm_frame(world: np.ndarray) -> np.ndarray:
    """A world pose (4x4) in the arm's base frame."""
    return np.linalg.inv(arm_base()) @ world


def frame(origin: np.ndarray, x: np.ndarray, z: np.ndarray) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = x, np.cross(z, x), z, origin
    return pose


def from_pose_vector(vector: list[float]) -> np.ndarray:
    """A UR pose vector (m, rotation vector) as a 4x4, by scipy (not the code under test)."""
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_rotvec(vector[3:]).as_matrix()
    pose[:3, 3] = vector[:3]
    return pose


def assert_same_pose(got: np.ndarray, want: np.ndarray) -> None:
    """Within 1e-9 m and 1e-9 rad."""
    assert np.linalg.norm(got[:3, 3] - want[:3, 3]) < 1e-9, (got, want)
    angle = Rotation.from_matrix(got[:3, :3].T @ want[:3, :3]).magnitude()
    assert angle < 1e-9, (angle, got, want)


async def call(http: aiohttp.ClientSession, method: str, url: str, body: Any = None) -> Any:
    async with http.request(method, url, json=body) as response:
        answer = await response.json()
        assert response.status in (200, 202), (url, response.status, answer)
        return answer


async def sample(http: aiohttp.ClientSession, base: str, robot: str) -> Any:
    """``GET /api/robots/{robot}/tcp``, once the robot has had its first sample (409 before)."""
    async with asyncio.timeout(30):
        while True:
            async with http.get(f"{base}/api/robots/{robot}/tcp") as response:
                if response.status != 409:
                    assert response.status == 200, await response.text()
                    return await response.json()
            await asyncio.sleep(0.1)


async def move_to(http: aiohttp.ClientSession, base: str, robot: str, q: list[float]) -> None:
    """Command a move and wait until the robot's joints (as sampled) are there."""
    await call(http, "POST", f"{base}/api/robots/{robot}/move", {"joints": q})
    async with asyncio.timeout(60):
        while True:
            now = await sample(http, base, robot)
            if np.allclose(now["joints"], q, rtol=0.0, atol=1e-12):
                return
            await asyncio.sleep(0.1)


async def touch(http: aiohttp.ClientSession, base: str, point_world: np.ndarray) -> list[float]:
    """Bring the arm's TCP to a world point (pointing down); the TCP sample there."""
    target = in_arm_frame(frame(point_world, np.array([1.0, 0, 0]), np.array([0, 0, 1.0])))
    tcp = [*target[:3, 3].tolist(), *DOWN]
    now = await sample(http, base, "arm")
    ik = await call(
        http, "POST", f"{base}/api/robots/arm/ik", {"tcp": tcp, "joints_ref": now["joints"]}
    )
    assert ik["ok"], ik
    await move_to(http, base, "arm", ik["best"])
    taken = await sample(http, base, "arm")
    # The sample is in the arm's base frame, and the TCP is on the mark.
    np.testing.assert_allclose(taken["tcp"][:3], target[:3, 3], rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(taken["world"][:3], point_world, rtol=0.0, atol=1e-12)
    tcp_sample: list[float] = taken["tcp"]
    return tcp_sample


@pytest.fixture
def cell_file(tmp_path: Path) -> Path:
    return written(tmp_path, CELL)


async def test_a_turntable_calibrated_from_three_tcp_samples_lands_where_it_is(
    cell_file: Path,
) -> None:
    settings = Settings(cell=cell_file, allow_edits=True, mock_hold_s=600.0)
    angles = np.radians([10.0, 75.0, 160.0])  # the second a positive turn, under half a turn
    async with running_server(settings) as base, aiohttp.ClientSession() as http:
        samples, first_joints = [], None
        for q in angles:
            await move_to(http, base, "positioner", [0.0, float(q)])
            mark = TURN_CENTRE + RADIUS * np.array([math.cos(q), math.sin(q), 0.0])
            samples.append(await touch(http, base, mark))
            if first_joints is None:
                first_joints = (await sample(http, base, "positioner"))["joints"]
        body = {"kind": "rotary", "headstock": samples}
        fit = await call(http, "POST", f"{base}/api/calibrate", body)
        # MotionPlus: origin at the circle's centre, +Z by the right-hand rule from the first
        # sample to the second, +X towards the first: the turntable's frame at 10 degrees.
        first_x = np.array([math.cos(angles[0]), math.sin(angles[0]), 0.0])
        truth = frame(TURN_CENTRE, first_x, np.array([0.0, 0.0, 1.0]))
        assert_same_pose(from_pose_vector(fit["pose"]), in_arm_frame(truth))
        assert fit["radius"] == pytest.approx(RADIUS, abs=1e-9)
        assert 0.0 <= fit["mean_error"] <= fit["max_error"] < 1e-9
        # Applied: the positioner's base goes where the machine has it, x = 1350 mm.
        change = {
            "op": "calibrated", "robot": "positioner", "measured_by": "arm",
            "pose": fit["pose"], "axis": "turn", "joints": first_joints,
        }  # fmt: skip
        status = await call(http, "POST", f"{base}/api/cell/changes", {"changes": [change]})
        assert (
            "+base = { xyz = [1350.0, 0.0, 0.0], rpy_deg = [0.0, 0.0, 0.0] }"
            in (status["unsaved"]["diff"])
        )
        robots = {r["name"]: r for r in await call(http, "GET", f"{base}/api/robots")}
        np.testing.assert_allclose(
            robots["positioner"]["base"], [1.35, 0, 0, 0, 0, 0, 1], rtol=0.0, atol=1e-9
        )
        # The model's turntable frame now is the calibrated one, at the joints it had then.
        asked = {"joints": [first_joints], "links": True}
        fk = await call(http, "POST", f"{base}/api/robots/positioner/fk", asked)
        table = from_pose7(fk["links"][0][2])
        assert_same_pose(pose7_matrix(robots["positioner"]["base"]) @ table, truth)
        await call(http, "POST", f"{base}/api/cell/save", {"version": status["unsaved"]["version"]})
    assert "base = { xyz = [1350.0, 0.0, 0.0], rpy_deg = [0.0, 0.0, 0.0] }" in cell_file.read_text()


def from_pose7(pose7: list[float]) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_quat(pose7[3:]).as_matrix()
    pose[:3, 3] = pose7[:3]
    return pose


pose7_matrix = from_pose7


async def test_a_rail_calibrated_from_its_carriage_lands_where_it_is(cell_file: Path) -> None:
    settings = Settings(cell=cell_file, allow_edits=True, mock_hold_s=600.0)
    async with running_server(settings) as base, aiohttp.ClientSession() as http:
        touched = []
        for s in (0.0, 0.1, 0.15):  # the carriage's mark at three positions (m)
            await move_to(http, base, "rail", [s])
            touched.append(await touch(http, base, RAIL_ORIGIN + s * RAIL_Z))
        await move_to(http, base, "rail", [0.0])
        towards_x = await touch(http, base, RAIL_ORIGIN + 0.1 * RAIL_X + 0.02 * RAIL_Z)
        body = {"kind": "linear", "origin": touched[0], "z_points": touched[1:], "x_dir": towards_x}
        fit = await call(http, "POST", f"{base}/api/calibrate", body)
        assert "radius" not in fit
        truth = frame(RAIL_ORIGIN, RAIL_X, RAIL_Z)
        assert_same_pose(from_pose_vector(fit["pose"]), in_arm_frame(truth))
        assert 0.0 <= fit["mean_error"] <= fit["max_error"] < 1e-9
        change = {
            "op": "calibrated", "robot": "rail", "measured_by": "arm",
            "pose": fit["pose"], "axis": "slide", "joints": [0.0],
        }  # fmt: skip
        await call(http, "POST", f"{base}/api/cell/changes", {"changes": [change]})
        (rail,) = [r for r in await call(http, "GET", f"{base}/api/robots") if r["name"] == "rail"]
        assert_same_pose(pose7_matrix(rail["base"]), truth)


async def test_the_motionplus_worked_examples_over_http() -> None:
    # Universal Robots, MotionPlus Axis Group API, "Axis Group Calibration": points exactly
    # on a circle centred at p[0, 0, 0.001, 0, 0, 0] with radius 0.1 give that pose, radius
    # 0.1 and no error; with the tailstock (on a circle at z = 0.1) the same pose.
    head = [[0.1, 0.0, 0.001, 0, 0, 0], [0.0, 0.1, 0.001, 0, 0, 0], [-0.1, 0.0, 0.001, 0, 0, 0]]
    tail = [[0.0, 0.2, 0.1, 0, 0, 0], [-0.2, 0.0, 0.1, 0, 0, 0], [0.0, -0.2, 0.1, 0, 0, 0]]
    async with running_server(Settings()) as base, aiohttp.ClientSession() as http:
        for body in ({"kind": "rotary", "headstock": head},
                     {"kind": "rotary", "headstock": head, "tailstock": tail}):  # fmt: skip
            fit = await call(http, "POST", f"{base}/api/calibrate", body)
            np.testing.assert_allclose(fit["pose"], [0, 0, 0.001, 0, 0, 0], atol=1e-12)
            assert fit["radius"] == pytest.approx(0.1, abs=1e-12)
            assert fit["max_error"] == pytest.approx(0.0, abs=1e-12)
            assert fit["mean_error"] == pytest.approx(0.0, abs=1e-12)
        # The linear example: origin p[0, 0.1, 0, ...], z points further along +Y, x_dir
        # p[0.1, 0.1, 0, ...] (as the document lists it) give p[0, 0.1, 0, -1.5708, 0, 0].
        body = {
            "kind": "linear", "origin": [0, 0.1, 0, 0, 0, 0],
            "z_points": [[0, 0.2, 0, 0, 0, 0], [0, 0.3, 0, 0, 0, 0]],
            "x_dir": [0.1, 0.1, 0, 0, 0, 0],
        }  # fmt: skip
        fit = await call(http, "POST", f"{base}/api/calibrate", body)
        np.testing.assert_allclose(fit["pose"], [0, 0.1, 0, -math.pi / 2, 0, 0], atol=1e-12)
        assert fit["max_error"] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize(
    ("body", "reason"),
    [
        ({"kind": "rotary", "headstock": [[0.1, 0, 0], [0, 0.1, 0]]},
         "the size of headstock must be at least 3, got 2"),
        ({"kind": "rotary", "headstock": [[0, 0, 0], [0.1, 0, 0], [0.2, 0, 0]]},
         "the samples are collinear, no circle fits them"),
        ({"kind": "rotary", "headstock": [[0.1, 0, 0], [-0.1, 0, 0], [0, 0.1, 0]]},
         "the first two headstock samples must not be opposite or coincide"),
        ({"kind": "rotary", "headstock": [[0.1, 0, 0], [0, 0.1, 0], [-0.1, 0, 0]],
          "tailstock": [[0.1, 0, 0], [0, 0.1, 0], [-0.1, 0, 0]]},
         "the headstock and tailstock centres coincide"),
        ({"kind": "linear", "origin": [0, 0, 0], "z_points": [], "x_dir": [1, 0, 0]},
         "the size of z_points must be at least 1, got 0"),
        ({"kind": "linear", "origin": [0, 0, 0], "z_points": [[0, 0, 0]], "x_dir": [1, 0, 0]},
         "the origin and z_points coincide, no line fits them"),
        ({"kind": "linear", "origin": [0, 0, 0], "z_points": [[0, 0, 0.1]], "x_dir": [0, 0, 0.3]},
         "x_dir lies on the fitted z axis"),
    ],
)  # fmt: skip
async def test_too_few_or_degenerate_samples_are_refused_with_the_reason(
    body: dict[str, Any], reason: str
) -> None:
    async with running_server(Settings()) as base, aiohttp.ClientSession() as http:
        async with http.post(f"{base}/api/calibrate", json=body) as response:
            assert response.status == 422
            assert (await response.json())["detail"] == reason


async def test_a_sample_is_the_tcp_the_stream_shows() -> None:
    # The demo cell's kin12 stands at (-750, 350, 0) mm: its TCP in the cell is its TCP in
    # its base frame moved there, and the joints are those /fk turns into that TCP.
    async with running_server(Settings()) as base, aiohttp.ClientSession() as http:
        taken = await sample(http, base, "kin12")
        fk = await call(http, "POST", f"{base}/api/robots/kin12/fk", {"joints": [taken["joints"]]})
        np.testing.assert_allclose(taken["tcp"][:3], fk["tcp"][0][:3], atol=1e-12)
        np.testing.assert_allclose(
            np.array(taken["world"][:3]) - taken["tcp"][:3], [-0.75, 0.35, 0.0], atol=1e-12
        )
        async with http.get(f"{base}/api/robots/nobody/tcp") as response:
            assert response.status == 404
