"""Coarse link meshes: few triangles, each part where, as large and as coloured as in the full."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from server.coarse import CoarseError, coarse_glb

ASSETS = Path(__file__).resolve().parents[2] / "assets"
DEMO_MESHES = sorted(ASSETS.glob("*/*.glb"))


def scene(data: bytes) -> Any:
    return trimesh.load(io.BytesIO(data), file_type="glb", force="scene")


def faces(loaded: Any) -> int:
    return sum(len(g.faces) for g in loaded.geometry.values())


def test_the_demo_cell_comes_to_a_few_thousand_triangles() -> None:
    full = [scene(path.read_bytes()) for path in DEMO_MESHES]
    coarse = [scene(coarse_glb(path.read_bytes())) for path in DEMO_MESHES]
    assert len(DEMO_MESHES) == 15
    assert sum(map(faces, full)) == 51_108
    assert sum(map(faces, coarse)) < 0.15 * sum(map(faces, full))
    assert all(faces(c) < 1000 for c in coarse), [faces(c) for c in coarse]


@pytest.mark.parametrize("path", DEMO_MESHES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_each_part_keeps_its_place_size_and_colour(path: Path) -> None:
    full = scene(path.read_bytes())
    coarse = scene(coarse_glb(path.read_bytes()))
    assert sorted(coarse.geometry) == sorted(full.geometry)  # part by part, by name
    # The surface moves by 1 % of the link's size at most (float32 on the way).
    slack = 0.01 * float(np.max(full.extents)) + 1e-6
    for name, part in full.geometry.items():
        simple = coarse.geometry[name]
        # The link frame stays the origin: the part's box where the full part's is.
        np.testing.assert_array_equal(coarse.graph[name][0], full.graph[name][0])
        np.testing.assert_allclose(simple.bounds, part.bounds, atol=slack)
        assert len(simple.faces) < len(part.faces) or len(part.faces) <= 12
        # Its material's colour, as glTF linear bytes.
        assert list(simple.visual.material.baseColorFactor) == list(
            part.visual.material.baseColorFactor
        )


def test_a_file_that_is_not_a_glb_has_no_coarse_mesh() -> None:
    with pytest.raises(CoarseError, match="cannot read it as a GLB"):
        coarse_glb(b"glTF" + b"\x02\x00\x00\x00" + b"\xff" * 64)
    empty = trimesh.Scene()
    empty.add_geometry(trimesh.PointCloud(np.zeros((3, 3))), geom_name="points")
    with pytest.raises(CoarseError, match="no triangles"):
        coarse_glb(bytes(trimesh.exchange.gltf.export_glb(empty)))


def glb_of(part: Any) -> bytes:
    part.visual = trimesh.visual.TextureVisuals(
        material=trimesh.visual.material.PBRMaterial(baseColorFactor=[200, 10, 10, 255])
    )
    one = trimesh.Scene()
    one.add_geometry(part, geom_name="part", node_name="part")
    return bytes(trimesh.exchange.gltf.export_glb(one))


def test_an_open_part_comes_down_to_its_share_within_its_bounds() -> None:
    # Half a finely tessellated sphere: open (no closed manifold), every edge ~1 cm long.
    ball = trimesh.creation.icosphere(subdivisions=4, radius=0.2)
    ball.update_faces(ball.triangles_center[:, 2] > 0)
    ball.remove_unreferenced_vertices()
    assert not ball.is_watertight and len(ball.faces) > 2000
    coarse = scene(coarse_glb(glb_of(ball), link_faces=200)).geometry["part"]
    assert len(coarse.faces) <= 1.5 * 200
    np.testing.assert_allclose(coarse.bounds, ball.bounds, atol=0.01 * 0.4 + 1e-6)


def test_a_closed_part_with_long_edges_comes_down_to_its_share_too() -> None:
    # A whole sphere of 5120 triangles: its edges (~1 cm) are longer than 1 % of its size.
    ball = trimesh.creation.icosphere(subdivisions=4, radius=0.2)
    coarse = scene(coarse_glb(glb_of(ball), link_faces=300)).geometry["part"]
    assert len(coarse.faces) <= 1.5 * 300
    np.testing.assert_allclose(coarse.bounds, ball.bounds, atol=0.01 * 0.4 + 1e-6)
