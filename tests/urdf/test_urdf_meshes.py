"""link_meshes: one GLB per link in its link frame, with the right colours, converted once.

GLBs are read back with trimesh; positions are float32 in glTF, hence the 1e-6.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh

from server.urdf import link_meshes, load_urdf, mesh_key
from server.urdf import meshes as meshes_module

FIXTURES = Path(__file__).parent / "fixtures"
MESH_DESCRIPTION = FIXTURES / "mesh_description"
PACKAGES = {"mesh_description": MESH_DESCRIPTION}
TOL = 1e-6


def glb(path: Path) -> trimesh.Scene:
    scene = trimesh.load(path, force="scene")
    assert isinstance(scene, trimesh.Scene)
    return scene


def colour(scene: trimesh.Scene) -> np.ndarray:
    """The base colour factor of the scene's only material, 0-255 (linear)."""
    (geometry,) = scene.geometry.values()
    return np.asarray(geometry.visual.material.baseColorFactor, dtype=float)


def test_each_link_with_visuals_gets_a_glb_in_its_link_frame(tmp_path: Path) -> None:
    robot = load_urdf(MESH_DESCRIPTION / "urdf" / "mesh_arm.urdf", PACKAGES)
    files = link_meshes(robot, tmp_path / "cache").files
    assert set(files) == {"base", "link1", "link2", "tool"}  # "slider" has no visual
    assert all(
        path.parent == tmp_path / "cache" and path.suffix == ".glb" for path in files.values()
    )
    # base.stl: a 0.2 x 0.2 x 0.1 box standing on z = 0, no visual origin.
    np.testing.assert_allclose(
        glb(files["base"]).bounds, [[-0.1, -0.1, 0], [0.1, 0.1, 0.1]], atol=TOL
    )
    # link1.dae is in millimetres: r 50, z 0..300; its visual is 0.02 up and turned about z.
    np.testing.assert_allclose(
        glb(files["link1"]).bounds, [[-0.05, -0.05, 0.02], [0.05, 0.05, 0.32]], atol=TOL
    )
    # link2: the same file, z halved, then laid along +x (pitch 90 deg) from x = 0.1.
    np.testing.assert_allclose(
        glb(files["link2"]).bounds, [[0.1, -0.05, -0.05], [0.25, 0.05, 0.05]], atol=TOL
    )
    # tool.stl: a 0.04 cube, x doubled, rolled 0.3 rad about x and lifted 0.02.
    cube = trimesh.creation.box((0.08, 0.04, 0.04))
    cube.apply_transform(trimesh.transformations.euler_matrix(0.3, 0, 0))
    cube.apply_translation((0, 0, 0.02))
    np.testing.assert_allclose(glb(files["tool"]).bounds, cube.bounds, atol=TOL)


def test_colours_come_from_the_mesh_or_else_the_urdf(tmp_path: Path) -> None:
    robot = load_urdf(MESH_DESCRIPTION / "urdf" / "mesh_arm.urdf", PACKAGES)
    files = link_meshes(robot, tmp_path).files
    # STL has no material: the URDF's blue (0.1, 0.3, 0.8), as a linear factor.
    linear = [((c + 0.055) / 1.055) ** 2.4 * 255 for c in (0.1, 0.3, 0.8)]
    np.testing.assert_allclose(colour(glb(files["base"]))[:3], linear, atol=1.0)
    # The COLLADA file brings its own red; it wins over the URDF's blue, as in RViz.
    for link in ("link1", "link2"):
        red, green, blue, _ = colour(glb(files[link]))
        assert red > 200 and green < 40 and blue < 40
    # Half-transparent green.
    red, green, blue, alpha = colour(glb(files["tool"]))
    assert green > red and green > blue and alpha == pytest.approx(127.5, abs=1)


def test_primitives(tmp_path: Path) -> None:
    robot = load_urdf(FIXTURES / "serial6.urdf")
    files = link_meshes(robot, tmp_path).files
    assert set(files) == {"base", "l1", "l2"}
    np.testing.assert_allclose(
        glb(files["base"]).bounds, [[-0.1, -0.1, -0.025], [0.1, 0.1, 0.025]], atol=TOL
    )
    np.testing.assert_allclose(
        glb(files["l1"]).bounds, [[-0.05, -0.06, 0.0], [0.05, 0.06, 0.2]], atol=TOL
    )
    vertices = np.concatenate([g.vertices for g in glb(files["l2"]).geometry.values()])
    np.testing.assert_allclose(np.linalg.norm(vertices, axis=1), 0.06, atol=TOL)


def test_a_warm_cache_converts_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    robot = load_urdf(MESH_DESCRIPTION / "urdf" / "mesh_arm.urdf", PACKAGES)
    calls: list[str] = []
    convert = meshes_module.convert_link

    def counting(link: str, visuals: tuple, stand_in: object) -> tuple[bytes, list[str]]:  # type: ignore[type-arg]
        calls.append(link)
        return convert(link, visuals, stand_in)  # type: ignore[arg-type]

    monkeypatch.setattr(meshes_module, "convert_link", counting)
    first = link_meshes(robot, tmp_path).files
    assert sorted(calls) == ["base", "link1", "link2", "tool"]
    stamps = {path: path.stat().st_mtime_ns for path in first.values()}
    calls.clear()
    again = link_meshes(
        load_urdf(MESH_DESCRIPTION / "urdf" / "mesh_arm.urdf", PACKAGES), tmp_path
    ).files
    assert again == first and calls == []
    assert {path: path.stat().st_mtime_ns for path in again.values()} == stamps
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in first.values())


def copy_description(tmp_path: Path) -> Path:
    folder = tmp_path / "mesh_description"
    shutil.copytree(MESH_DESCRIPTION, folder)
    return folder


def test_a_changed_source_changes_the_key_and_the_glb(tmp_path: Path) -> None:
    folder = copy_description(tmp_path)
    urdf = folder / "urdf" / "mesh_arm.urdf"
    before = link_meshes(load_urdf(urdf, {"mesh_description": folder}), tmp_path / "cache").files
    # Same content elsewhere: same keys.
    original = link_meshes(
        load_urdf(MESH_DESCRIPTION / "urdf" / "mesh_arm.urdf", PACKAGES), tmp_path / "cache"
    ).files
    assert original == before
    bigger = trimesh.creation.box((0.4, 0.2, 0.1))
    (folder / "meshes" / "base.stl").write_bytes(trimesh.exchange.stl.export_stl(bigger))
    after = link_meshes(load_urdf(urdf, {"mesh_description": folder}), tmp_path / "cache").files
    assert after["base"] != before["base"]
    assert {k: v for k, v in after.items() if k != "base"} == {
        k: v for k, v in before.items() if k != "base"
    }
    np.testing.assert_allclose(glb(after["base"]).bounds[:, 0], [-0.2, 0.2], atol=TOL)


def test_the_key_follows_the_visual_not_the_joints(tmp_path: Path) -> None:
    folder = copy_description(tmp_path)
    urdf = folder / "urdf" / "mesh_arm.urdf"
    text = urdf.read_text()

    def keys(new_text: str) -> dict[str, str]:
        urdf.write_text(new_text)
        robot = load_urdf(urdf, {"mesh_description": folder})
        return {link: mesh_key(link, v) for link, v in robot.visuals.items() if v}

    base = keys(text)
    moved_joint = keys(
        text.replace(
            '<origin xyz="0 0 0.32" rpy="0.1 0.2 0.3"/>',
            '<origin xyz="0 0 0.4" rpy="0.1 0.2 0.3"/>',
        )
    )
    assert moved_joint == base
    recoloured = keys(text.replace('rgba="0.1 0.7 0.2 0.5"', 'rgba="0.1 0.7 0.2 1"'))
    assert recoloured["tool"] != base["tool"] and recoloured["base"] == base["base"]
    rescaled = keys(text.replace('scale="1 1 0.5"', 'scale="1 1 0.6"'))
    assert rescaled["link2"] != base["link2"] and rescaled["link1"] == base["link1"]
    moved_visual = keys(
        text.replace(
            '<origin xyz="0.1 0 0" rpy="0 1.5707963267948966 0"/>',
            '<origin xyz="0.2 0 0" rpy="0 1.5707963267948966 0"/>',
        )
    )
    assert moved_visual["link2"] != base["link2"]


def test_obj_materials_are_part_of_the_key(tmp_path: Path) -> None:
    mesh = trimesh.creation.cylinder(0.05, 0.2, sections=8)
    red = trimesh.visual.material.SimpleMaterial(diffuse=[200, 30, 30, 255])
    mesh.visual = trimesh.visual.TextureVisuals(material=red)
    text, files = trimesh.exchange.obj.export_obj(mesh, return_texture=True, mtl_name="cyl.mtl")
    (tmp_path / "cyl.obj").write_text(text)
    (tmp_path / "cyl.mtl").write_bytes(files["cyl.mtl"])
    urdf = tmp_path / "obj.urdf"
    urdf.write_text(
        '<robot name="o"><link name="a"><visual><geometry>'
        '<mesh filename="cyl.obj"/></geometry></visual></link></robot>'
    )
    robot = load_urdf(urdf)
    first = link_meshes(robot, tmp_path / "cache").files["a"]
    red_channel, green, _, _ = colour(glb(first))
    assert red_channel > 150 and green < 40
    mtl = (tmp_path / "cyl.mtl").read_text().replace("Kd 0.78431373 0.11764706", "Kd 0.1 0.9")
    (tmp_path / "cyl.mtl").write_text(mtl)
    second = link_meshes(load_urdf(urdf), tmp_path / "cache").files["a"]
    assert second != first
    red_channel, green, _, _ = colour(glb(second))
    assert green > red_channel


def one_mesh_robot(folder: Path, mesh: Path) -> Path:
    urdf = folder / "one.urdf"
    urdf.write_text(
        f'<robot name="one"><link name="a"><visual><geometry><mesh filename="{mesh}"/>'
        "</geometry></visual></link></robot>"
    )
    return urdf


CYLINDER_MM_BOUNDS = [[-0.05, -0.05, 0.0], [0.05, 0.05, 0.3]]  # link1.dae, r 50 mm, 300 mm high


def test_a_collada_file_with_a_broken_material_keeps_its_shape(tmp_path: Path) -> None:
    # As Blender 2.79 exported ANYmal's foot: an effect's sampler names a surface that
    # is not in the file. pycollada then drops the node; the shape must stay.
    text = (MESH_DESCRIPTION / "meshes" / "link1.dae").read_text()
    sampler = (
        '<newparam sid="tex-sampler"><sampler2D><source>missing-surface</source></sampler2D>'
        "</newparam><technique"
    )
    text = text.replace("<technique", sampler, 1).replace(
        "<diffuse>\n              <color>0.8627450980392157 0.11764705882352941 "
        "0.11764705882352941 1.0</color>",
        '<diffuse>\n              <texture texture="tex-sampler" texcoord="UVMap"/>',
    )
    assert "missing-surface" in text and 'texture="tex-sampler"' in text
    broken = tmp_path / "broken_material.dae"
    broken.write_text(text)
    assert not trimesh.load(broken, force="scene").geometry  # as trimesh alone reads it
    meshes = link_meshes(load_urdf(one_mesh_robot(tmp_path, broken)), tmp_path / "cache")
    assert meshes.warnings == ()
    np.testing.assert_allclose(glb(meshes.files["a"]).bounds, CYLINDER_MM_BOUNDS, atol=TOL)


def test_a_collada_file_with_a_text_node_past_ten_megabytes_converts(tmp_path: Path) -> None:
    # Unitree's B1 trunk.dae holds one float array of 10 MB: past lxml's default limit.
    text = (MESH_DESCRIPTION / "meshes" / "link1.dae").read_text()
    big = text.replace("</float_array>", " " * 10_000_100 + "</float_array>", 1)
    huge = tmp_path / "huge.dae"
    huge.write_text(big)
    meshes = link_meshes(load_urdf(one_mesh_robot(tmp_path, huge)), tmp_path / "cache")
    assert meshes.warnings == ()
    np.testing.assert_allclose(glb(meshes.files["a"]).bounds, CYLINDER_MM_BOUNDS, atol=TOL)
