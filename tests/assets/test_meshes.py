"""Committed link meshes: what the script builds, modelled in their link frames.

Each ``assets/<robot>/<link>.glb`` must have its origin at the link's pivot
(seed 000, Figure 11), because the page sets each link's pose straight from the
frame message. The checks below state where each pivot and axis must be.
"""

from __future__ import annotations

import colorsys
import subprocess
import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import trimesh

ASSETS = Path(__file__).resolve().parents[2] / "assets"
LINKS = {
    "kin12": ["L1", "L5", "L4", "L2"],
    "iiwa7": [f"link{i}" for i in range(8)],
    "positioner": ["base", "tilt", "table"],
}
IIWA_D = (0.34, 0.0, 0.40, 0.0, 0.40, 0.0, 0.126)
TOL = 1e-6


@cache
def scene(robot: str, link: str) -> trimesh.Scene:
    """The committed mesh as a scene (one node per part)."""
    loaded = trimesh.load(ASSETS / robot / f"{link}.glb", force="scene")
    assert isinstance(loaded, trimesh.Scene)
    return loaded


def part(robot: str, link: str, name: str) -> trimesh.Trimesh:
    geometry = scene(robot, link).geometry[name]
    assert isinstance(geometry, trimesh.Trimesh)
    return geometry


def bounds(robot: str, link: str, name: str | None = None) -> np.ndarray:
    """Axis-aligned bounds (2x3, metres, link frame) of a part or of the whole link."""
    if name is None:
        return np.asarray(scene(robot, link).bounds)
    return np.asarray(part(robot, link, name).bounds)


def test_committed_meshes_are_what_the_script_builds(tmp_path: Path) -> None:
    # Bytes differ between trimesh and numpy versions (triangle order, buffer layout), so
    # compare what the page draws: every part's triangles with their winding, normals and
    # material. A fresh install resolves whatever versions are current.
    subprocess.run(
        [sys.executable, str(ASSETS / "build_meshes.py"), "--out", str(tmp_path)],
        check=True,
        capture_output=True,
    )
    built = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*.glb"))
    committed = sorted(p.relative_to(ASSETS) for p in ASSETS.rglob("*.glb"))
    expected = sorted(
        Path(robot) / f"{link}.glb" for robot, links in LINKS.items() for link in links
    )
    assert built == committed == expected
    for path in built:
        rebuilt = trimesh.load(tmp_path / path, force="scene")
        assert list(rebuilt.geometry) == list(scene(path.parent.name, path.stem).geometry), path
        for name, geometry in rebuilt.geometry.items():
            assert_same_part(part(path.parent.name, path.stem, name), geometry, f"{path}:{name}")


def triangles(mesh: trimesh.Trimesh) -> np.ndarray:
    """Every triangle as 9 coordinates from its smallest corner on (winding kept), sorted."""
    corners = np.asarray(mesh.vertices)[np.asarray(mesh.faces)]  # (F, 3 corners, 3)
    key = np.round(corners, 6).reshape(-1, 3)  # order by what float32 files keep
    rank = np.empty(len(key), dtype=np.int64)
    rank[np.lexsort(key.T[::-1])] = np.arange(len(key))
    first = rank.reshape(-1, 3).argmin(axis=1)
    turn = (first[:, None] + np.arange(3)) % 3
    rolled = corners[np.arange(len(corners))[:, None], turn].reshape(-1, 9)
    return rolled[np.lexsort(np.round(rolled, 6).T[::-1])]


def assert_same_part(committed: trimesh.Trimesh, rebuilt: trimesh.Trimesh, where: str) -> None:
    assert len(rebuilt.faces) == len(committed.faces), where
    np.testing.assert_allclose(triangles(rebuilt), triangles(committed), atol=TOL, err_msg=where)
    np.testing.assert_allclose(rebuilt.area, committed.area, rtol=1e-9, err_msg=where)
    old, new = committed.visual.material, rebuilt.visual.material
    assert (new.name, new.metallicFactor, new.roughnessFactor) == (
        old.name, old.metallicFactor, old.roughnessFactor
    ), where  # fmt: skip
    np.testing.assert_array_equal(new.baseColorFactor, old.baseColorFactor, err_msg=where)


@pytest.mark.parametrize(
    ("robot", "link"), [(r, name) for r, links in LINKS.items() for name in links]
)
def test_link_mesh_is_a_plain_scene_in_the_link_frame(robot: str, link: str) -> None:
    loaded = scene(robot, link)
    assert loaded.geometry, "no geometry"
    for node in loaded.graph.nodes_geometry:
        transform, _ = loaded.graph[node]
        np.testing.assert_allclose(transform, np.eye(4), atol=TOL, err_msg=node)
    for name, geometry in loaded.geometry.items():
        assert len(geometry.faces) > 0, name
        assert np.isfinite(geometry.vertices).all(), name


@pytest.mark.parametrize(
    ("robot", "hue_range"),
    [("kin12", (0.55, 0.7)), ("iiwa7", (0.0, 0.12)), ("positioner", (0.4, 0.55))],
)
def test_each_robot_wears_its_colour(robot: str, hue_range: tuple[float, float]) -> None:
    """The saturated material covering the most surface has the robot's hue (blue, orange, teal)."""
    area_by_hue: dict[float, float] = {}
    for link in LINKS[robot]:
        for geometry in scene(robot, link).geometry.values():
            rgba = np.asarray(geometry.visual.material.baseColorFactor, dtype=float) / 255.0
            h, _, s = colorsys.rgb_to_hls(*rgba[:3])
            if s > 0.5:
                area_by_hue[round(h, 3)] = area_by_hue.get(round(h, 3), 0.0) + geometry.area
    assert area_by_hue, f"{robot} has no saturated material"
    hue = max(area_by_hue, key=lambda h: area_by_hue[h])
    assert hue_range[0] <= hue <= hue_range[1], area_by_hue


# -- kin12: bars along +X from their pivots, stacked without overlapping ------------------

BAR = {
    "L1": (0.2, [0.0, 0.2]),
    "L5": (0.1, [0.0, 0.1]),
    "L4": (0.2, [0.0, 0.2]),
    "L2": (0.15, [0.0, 0.1, 0.15]),
}
"""Bar length and the x of its holes (m), link frame."""


@pytest.mark.parametrize("link", LINKS["kin12"])
def test_kin12_bar_runs_from_its_pivot_along_x(link: str) -> None:
    length, holes = BAR[link]
    (x0, y0, _), (x1, y1, _) = bounds("kin12", link, f"{link}_bar")
    r = y1
    assert 0.005 < r < 0.03
    assert y0 == pytest.approx(-r, abs=TOL)
    assert x0 == pytest.approx(-r, abs=TOL)
    assert x1 == pytest.approx(length + r, abs=TOL)

    # Round holes at the pivots: no material nearer to a hole's axis than its radius.
    vertices = part("kin12", link, f"{link}_bar").vertices
    for x in holes:
        nearest = np.hypot(vertices[:, 0] - x, vertices[:, 1]).min()
        assert 0.003 < nearest < r, (link, x, nearest)


def test_kin12_bars_are_stacked_l5_l1_l4_l2_without_touching() -> None:
    layers = [bounds("kin12", link, f"{link}_bar")[:, 2] for link in ("L5", "L1", "L4", "L2")]
    for (_, top), (bottom, _) in zip(layers[:-1], layers[1:], strict=True):
        assert top < bottom


def test_kin12_pins_sit_on_the_pivot_axes() -> None:
    for link, name, x in [
        ("L1", "L1_pin_O", 0.0),
        ("L4", "L4_pin_W", 0.0),
        ("L2", "L2_pin_T", 0.0),
        ("L2", "L2_pin_E", 0.1),
    ]:
        centre = bounds("kin12", link, name)[:, :2].mean(axis=0)
        np.testing.assert_allclose(centre, [x, 0.0], atol=TOL, err_msg=name)


# -- iiwa7: each link in its DH frame ---------------------------------------------------------


def test_iiwa_base_column_reaches_the_first_joint() -> None:
    (_, _, z0), (_, _, z1) = bounds("iiwa7", "link0")
    assert z0 == pytest.approx(0.0, abs=TOL)
    assert z1 == pytest.approx(IIWA_D[0], abs=TOL)


@pytest.mark.parametrize("i", range(1, 7))
def test_iiwa_link_has_a_housing_at_its_origin_and_reaches_the_next_frame(i: int) -> None:
    housing = bounds("iiwa7", f"link{i}", f"link{i}_housing")
    np.testing.assert_allclose(housing.mean(axis=0), 0.0, atol=TOL)
    assert housing[1, 0] == pytest.approx(0.06, abs=0.005)

    whole = bounds("iiwa7", f"link{i}")
    d_next = IIWA_D[i]
    np.testing.assert_allclose(whole[:, :2], [[-0.06, -0.06], [0.06, 0.06]], atol=0.005)
    if d_next > 0.0:
        assert whole[1, 2] == pytest.approx(d_next, abs=TOL)
    else:
        assert whole[1, 2] == pytest.approx(-whole[0, 2], abs=TOL)


def test_iiwa_flange_faces_plus_z_at_the_origin() -> None:
    (x0, _, z0), (x1, _, z1) = bounds("iiwa7", "link7", "link7_flange")
    assert (x0, x1) == (pytest.approx(-0.04, abs=TOL), pytest.approx(0.04, abs=TOL))
    assert (z0, z1) == (pytest.approx(-0.01, abs=TOL), pytest.approx(0.0, abs=TOL))


# -- positioner: tilt axis along base +X at z = 0.45, table surface at the table origin -------


def test_positioner_base_carries_the_tilt_axis() -> None:
    (x0, _, z0), (x1, _, _) = bounds("positioner", "base", "base_uprights")
    assert z0 > 0.0 and bounds("positioner", "base")[0, 2] == pytest.approx(0.0, abs=TOL)
    assert (x0 + 0.35, x1 - 0.35) == (pytest.approx(-0.03, abs=TOL), pytest.approx(0.03, abs=TOL))
    bearings = bounds("positioner", "base", "base_bearings")
    np.testing.assert_allclose(bearings.mean(axis=0)[1:], [0.0, 0.45], atol=TOL)


def test_positioner_cradle_hangs_on_the_tilt_axis_under_the_table() -> None:
    # Tilt frame: +Z along the tilt axis, -X up at zero tilt; the table's underside
    # is 0.08 above the axis (tilt x = -0.08).
    (x0, _, z0), (x1, _, z1) = bounds("positioner", "tilt", "tilt_plate")
    assert (z0, z1) == (pytest.approx(-0.3, abs=TOL), pytest.approx(0.3, abs=TOL))
    assert -0.08 < x0 < x1 < 0.0, "the plate lies between the axis and the table"
    arms = bounds("positioner", "tilt", "tilt_arms")
    assert arms[0, 2] == pytest.approx(-0.3, abs=TOL) and arms[1, 2] == pytest.approx(0.3, abs=TOL)
    trunnions = bounds("positioner", "tilt", "tilt_trunnions")
    np.testing.assert_allclose(trunnions.mean(axis=0)[:2], 0.0, atol=TOL)
    assert trunnions[1, 2] == pytest.approx(0.32, abs=TOL)  # meets the upright at x = 0.35 - 0.03


def test_positioner_table_surface_is_its_origin() -> None:
    (x0, y0, z0), (x1, y1, z1) = bounds("positioner", "table", "table_disc")
    np.testing.assert_allclose([x0, y0, x1, y1], [-0.25, -0.25, 0.25, 0.25], atol=TOL)
    assert (z0, z1) == (pytest.approx(-0.02, abs=TOL), pytest.approx(0.0, abs=TOL))
    slots = bounds("positioner", "table", "table_slots")
    assert slots[1, 2] > 0.0, "slots must show above the surface so the rotation is visible"


# -- agreement with the server's kinematics ----------------------------------------------------


def _apply(pose: np.ndarray, point: list[float]) -> np.ndarray:
    return np.asarray(pose[:3, :3] @ np.asarray(point) + pose[:3, 3])


def test_kin12_holes_meet_where_the_kinematics_joins_the_bars() -> None:
    """Hole x positions (checked against the meshes above) joined by Type12.link_poses."""
    from server.kinematics import Type12

    rng = np.random.default_rng(0)
    q = rng.uniform(-0.5, 0.5, size=(50, 2))
    poses, ok = Type12().link_poses(q)
    assert ok.all()
    for pose in poses:
        l1, l5, l4, l2 = pose
        joints = [
            ("T", _apply(l1, [BAR["L1"][1][1], 0, 0]), _apply(l2, [0, 0, 0])),
            ("W", _apply(l5, [BAR["L5"][1][1], 0, 0]), _apply(l4, [0, 0, 0])),
            ("E", _apply(l4, [BAR["L4"][1][1], 0, 0]), _apply(l2, [BAR["L2"][1][1], 0, 0])),
        ]
        for name, a, b in joints:
            np.testing.assert_allclose(a, b, atol=1e-9, err_msg=name)


def test_positioner_table_rests_on_the_cradle_at_every_tilt() -> None:
    from tests.conftest import demo_cell

    positioner = next(r for r in demo_cell().robots if r.name == "positioner")
    for tilt in np.radians([-60.0, 0.0, 45.0]):
        poses, ok = positioner.kinematics.link_poses(np.array([tilt, 0.3]))
        assert ok
        _, tilt_pose, table_pose = poses
        in_tilt = np.linalg.inv(tilt_pose) @ table_pose
        underside = _apply(in_tilt, [0.0, 0.0, bounds("positioner", "table", "table_disc")[0, 2]])
        plate_top = bounds("positioner", "tilt", "tilt_plate")[0, 0]
        assert underside[0] < plate_top < underside[0] + 0.01, (underside, plate_top)
