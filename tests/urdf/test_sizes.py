"""Large honest descriptions load; past each bound a description is refused naming the limit.

Bounds (``server.sizes``, ``server.urdf.meshes``, ``server.clearance.shapes``):
256 movable joints and 2 048 links per robot, names of 256 characters, mesh
files of 64 MB, 500 000 vertices per link after conversion, and collision
hulls of at most 256 vertices.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

from server.cell import load_cell
from server.clearance import shapes
from server.sizes import MAX_JOINTS, MAX_LINKS
from server.urdf import UrdfError, link_meshes, load_urdf, meshes
from tests.sandbox.hostile import CELL
from tests.urdf.corpus import tree_urdf


def test_a_robot_of_the_largest_size_loads_as_a_cell(tmp_path: Path) -> None:
    (tmp_path / "big.urdf").write_text(tree_urdf(MAX_LINKS, MAX_JOINTS))
    joints = ", ".join(f'{{ node = "n{k}", unit = "rad" }}' for k in range(MAX_JOINTS))
    cell = tmp_path / "cell.toml"
    cell.write_text(
        CELL.format(extra="")
        .replace("arm.urdf.xacro", "big.urdf")
        .replace(
            '[ { node = "motion/axs/Axis_1/state/values/actual/pos", unit = "rad" } ]',
            f"[ {joints} ]",
        )
    )
    (robot,) = load_cell(cell, env={}, cache_dir=tmp_path / "cache").robots
    assert len(robot.joints) == MAX_JOINTS and len(robot.link_names) == MAX_LINKS
    poses, ok = robot.kinematics.link_poses(np.full(MAX_JOINTS, 0.1))
    assert ok and poses.shape == (MAX_LINKS, 4, 4)


@pytest.mark.parametrize("chain", [False, True])
def test_the_links_a_kernel_needs_are_every_path_to_the_root(chain: bool, tmp_path: Path) -> None:
    # Tree.needed walks up once per link (linear); the paths it replaces, unioned, were
    # quadratic along a chain: 4 000 links loaded in 16.3 s before, 4.4 s after.
    (tmp_path / "r.urdf").write_text(tree_urdf(300, 40, chain=chain))
    tree = load_urdf(tmp_path / "r.urdf").chain._tree
    rng = np.random.default_rng(3)
    for size in (1, 5, 300):
        outputs = [int(i) for i in rng.choice(300, size, replace=False)]
        union = sorted({i for link in outputs for i in tree.path(link)})
        assert tree.needed(outputs) == union


@pytest.mark.parametrize(
    ("links", "movable", "name", "refusal"),
    [
        (MAX_LINKS + 1, 0, "l", f"more than {MAX_LINKS} links; linkview draws at most"),
        (MAX_JOINTS + 2, MAX_JOINTS + 1, "l", f"{MAX_JOINTS + 1} movable joints; linkview"),
        (3, 1, "x" * 300, "name of 301 characters; linkview takes at most 256"),
    ],
)
def test_past_a_bound_the_description_is_refused(
    links: int, movable: int, name: str, refusal: str, tmp_path: Path
) -> None:
    (tmp_path / "r.urdf").write_text(tree_urdf(links, movable, name))
    with pytest.raises(UrdfError, match=str(tmp_path)) as caught:
        load_urdf(tmp_path / "r.urdf")
    assert refusal in str(caught.value)


def mesh_robot(folder: Path, mesh: str) -> Path:
    (folder / "r.urdf").write_text(
        '<robot name="r"><link name="a"><visual><geometry>'
        f'<mesh filename="{mesh}"/></geometry></visual></link></robot>'
    )
    return folder / "r.urdf"


def test_a_mesh_file_past_the_limit_is_not_read(tmp_path: Path) -> None:
    huge = tmp_path / "huge.stl"
    with huge.open("wb") as f:  # sparse: takes no disk, would take 1 GB of memory to read
        f.truncate(1 << 30)
    robot = load_urdf(mesh_robot(tmp_path, "huge.stl"))
    started = time.monotonic()
    glbs = link_meshes(robot, tmp_path / "cache")
    (warning,) = glbs.warnings
    assert "it is 1074 MB, over linkview's limit of 64 MB for a mesh file" in warning
    assert "drawn as a stand-in" in warning and "a" in glbs.files
    assert time.monotonic() - started < 60
    os.remove(huge)


def test_a_link_past_the_vertex_limit_is_a_stand_in(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    sphere = trimesh.creation.icosphere(subdivisions=3)  # 642 vertices
    sphere.export(tmp_path / "ball.stl")
    robot = load_urdf(mesh_robot(tmp_path, "ball.stl"))
    assert link_meshes(robot, tmp_path / "fine").warnings == ()
    monkeypatch.setattr(meshes, "MAX_LINK_VERTICES", 600)
    (warning,) = link_meshes(robot, tmp_path / "coarse").warnings
    assert "more than 600 vertices after conversion, linkview's limit per link" in warning


def test_a_fine_mesh_gets_a_small_hull_that_still_holds_it(tmp_path: Path) -> None:
    sphere = trimesh.creation.icosphere(subdivisions=7, radius=0.1)  # 163 842 vertices
    sphere.export(tmp_path / "ball.glb")
    hull = shapes._hull(tmp_path / "ball.glb")
    assert hull is not None and len(hull.vertices) <= shapes.MAX_HULL_VERTICES + 6
    radii = np.linalg.norm(hull.vertices, axis=1)
    assert np.allclose(radii, 0.1, atol=1e-6)  # its corners lie on the sphere
    # Points of the sphere lie within the hull but for a sliver: the chord sag of a
    # 256-vertex sphere, about 1 - cos(angle between neighbours) of its radius.
    inside = hull.nearest.signed_distance(sphere.vertices[::97])
    assert inside.min() > -0.1 * 0.05
