"""Each link's visuals converted once into one GLB, cached by the content of its sources.

A GLB's scene origin is the link frame (m, Z up), the convention of the shipped
meshes in ``assets/``: the page places it by the link pose and nothing else.
Meshes keep their own materials (as RViz shows them); meshes without any, and
primitives, get the URDF colour, or grey. COLLADA ``<unit meter>`` scaling is
applied; its ``up_axis`` is not, as in RViz. Faces meeting at more than 35
degrees get separate normals, so flat STL facets look flat and round parts round.

The cache key hashes everything the output depends on: the bytes of every mesh
file and of the material and texture files it names, the visual origins,
scales, colours and primitive sizes, the link name and the trimesh version.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from lxml import etree

from .model import BoxGeometry, CylinderGeometry, MeshGeometry, SphereGeometry, UrdfRobot, Visual

# trimesh is only partly annotated, and mypy --strict would flag every call into it.
tm: Any = trimesh

FORMAT = 1  # bump when the conversion below changes its output
SHARP = np.radians(35.0)
SECTIONS = 32  # segments around cylinders
_GREY = (0.6, 0.6, 0.62, 1.0)
_OBJ_REFS = re.compile(rb"^\s*(?:mtllib|map_\w+)\s+(.+?)\s*$", re.M)
_DAE_REFS = re.compile(rb"<init_from>\s*([^<]+?)\s*</init_from>")


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _dependencies(path: Path) -> list[Path]:
    """Files a mesh names that change its looks: OBJ material libraries and textures, DAE images."""
    data = path.read_bytes()
    suffix = path.suffix.lower()
    if suffix == ".obj":
        names = _OBJ_REFS.findall(data)
        out = []
        for name in names:
            lib = path.parent / name.decode(errors="replace")
            if lib.is_file():
                out.append(lib)
                out += [
                    lib.parent / n.decode(errors="replace")
                    for n in _OBJ_REFS.findall(lib.read_bytes())
                ]
        return [p for p in out if p.is_file()]
    if suffix == ".dae":
        names = [
            n.decode(errors="replace").removeprefix("file://") for n in _DAE_REFS.findall(data)
        ]
        return [p for p in (path.parent / n for n in names) if p.is_file()]
    return []


def _describe(visual: Visual) -> dict[str, Any]:
    geometry = visual.geometry
    item: dict[str, Any] = {
        "origin": np.asarray(visual.origin).tolist(),
        "rgba": visual.rgba,
        "kind": type(geometry).__name__,
    }
    if isinstance(geometry, MeshGeometry):
        item["format"] = geometry.path.suffix.lower()
        item["scale"] = geometry.scale
        item["sources"] = [_digest(geometry.path)] + [
            _digest(p) for p in _dependencies(geometry.path)
        ]
    else:
        item["size"] = vars(geometry)
    return item


def mesh_key(link: str, visuals: tuple[Visual, ...]) -> str:
    """Content hash naming the GLB of ``link`` with ``visuals``."""
    description = {
        "format": FORMAT,
        "trimesh": tm.__version__,
        "link": link,
        "visuals": [_describe(v) for v in visuals],
    }
    text = json.dumps(description, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _material(rgba: tuple[float, float, float, float] | None) -> Any:
    r, g, b, a = rgba or _GREY
    # glTF colour factors are linear; URDF colours are picked in sRGB.
    linear = [((c + 0.055) / 1.055) ** 2.4 if c > 0.04045 else c / 12.92 for c in (r, g, b)]
    return tm.visual.material.PBRMaterial(
        baseColorFactor=[*linear, a],
        metallicFactor=0.1,
        roughnessFactor=0.55,
        alphaMode="BLEND" if a < 1.0 else None,
    )


def _textured(visual: Any) -> bool:
    material = getattr(visual, "material", None)
    return visual.kind == "texture" and (
        getattr(material, "image", None) is not None
        or getattr(material, "baseColorTexture", None) is not None
    )


def _finish(mesh: Any, rgba: tuple[float, float, float, float] | None) -> Any:
    """``mesh`` with crisp edges and a material, unless it brings textures or per-vertex colours."""
    visual = mesh.visual
    if _textured(visual) or visual.kind in ("vertex", "face"):
        return mesh
    material = visual.material if visual.kind == "texture" else _material(rgba)
    mesh.merge_vertices()
    shaded = tm.graph.smooth_shade(mesh, angle=SHARP, facet_minarea=None)
    shaded.metadata.clear()
    shaded.visual = tm.visual.TextureVisuals(material=material)
    return shaded


def _collada_unit(path: Path) -> float:
    """Metres per unit of a COLLADA file (``<asset><unit meter>``), 1 if not given."""
    unit = etree.parse(str(path)).getroot().find("{*}asset/{*}unit")
    return 1.0 if unit is None else float(unit.get("meter", "1"))


def _meshes(visual: Visual) -> list[Any]:
    """The visual's geometry in the link frame, finished."""
    geometry = visual.geometry
    if isinstance(geometry, MeshGeometry):
        scene = tm.load(geometry.path, force="scene")
        unit = _collada_unit(geometry.path) if geometry.path.suffix.lower() == ".dae" else 1.0
        scale = np.diag([*(unit * s for s in geometry.scale), 1.0])
        parts = []
        for node in scene.graph.nodes_geometry:
            transform, name = scene.graph[node]
            part = scene.geometry[name].copy()
            part.apply_transform(visual.origin @ scale @ transform)
            parts.append(part)
    elif isinstance(geometry, BoxGeometry):
        parts = [tm.creation.box(extents=geometry.size, transform=visual.origin)]
    elif isinstance(geometry, CylinderGeometry):
        parts = [
            tm.creation.cylinder(
                geometry.radius, geometry.length, sections=SECTIONS, transform=visual.origin
            )
        ]
    else:
        assert isinstance(geometry, SphereGeometry)
        sphere = tm.creation.icosphere(subdivisions=2, radius=geometry.radius)
        parts = [sphere.apply_transform(visual.origin)]
    return [_finish(part, visual.rgba) for part in parts]


def convert_link(link: str, visuals: tuple[Visual, ...]) -> bytes:
    """One binary glTF of ``link``'s visuals, its scene origin the link frame (m, Z up)."""
    scene = tm.Scene()
    k = 0
    for visual in visuals:
        for mesh in _meshes(visual):
            scene.add_geometry(mesh, node_name=f"{link}_{k}", geom_name=f"{link}_{k}")
            k += 1
    return bytes(tm.exchange.gltf.export_glb(scene, include_normals=True))


def link_meshes(robot: UrdfRobot, cache_dir: str | Path) -> dict[str, Path]:
    """GLB file per link that has visuals, converted only if ``cache_dir`` lacks it.

    Files are named by ``mesh_key``; one is written to a temporary name and
    renamed, so a reader never sees half a file.
    """
    cache = Path(cache_dir)
    cache.mkdir(parents=True, exist_ok=True)
    out: dict[str, Path] = {}
    for link, visuals in robot.visuals.items():
        if not visuals:
            continue
        path = cache / f"{mesh_key(link, visuals)}.glb"
        if not path.is_file():
            data = convert_link(link, visuals)
            fd, tmp = tempfile.mkstemp(dir=cache, suffix=".tmp")
            with os.fdopen(fd, "wb") as f:
                f.write(data)
            os.replace(tmp, path)
        out[link] = path
    return out
