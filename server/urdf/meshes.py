"""Each link's visuals converted once into one GLB, cached by the content of its sources.

A GLB's scene origin is the link frame (m, Z up), the convention of the shipped
meshes in ``assets/``: the page places it by the link pose and nothing else.
Meshes keep their own materials (as RViz shows them); meshes without any, and
primitives, get the URDF colour, or grey. COLLADA ``<unit meter>`` scaling is
applied; its ``up_axis`` is not, as in RViz. Faces meeting at more than 35
degrees get separate normals, so flat STL facets look flat and round parts round.
A mesh that cannot be read is drawn as the link's stand-in (a ball on the link
frame, sticks to its children) with a warning; the warning is kept beside the
cached GLB, so a warm cache reports it too.

The cache key hashes everything the output depends on: the bytes of every mesh
file and of the material and texture files it names, the visual origins,
scales, colours and primitive sizes, the link name and the trimesh version.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from lxml import etree

from .model import (
    BoxGeometry,
    CapsuleGeometry,
    CylinderGeometry,
    MeshGeometry,
    SphereGeometry,
    StandInGeometry,
    UrdfRobot,
    Visual,
)

# trimesh is only partly annotated, and mypy --strict would flag every call into it.
tm: Any = trimesh

FORMAT = 2  # bump when the conversion below changes its output
SHARP = np.radians(35.0)
SECTIONS = 32  # segments around cylinders
STAND_IN_RADIUS = 0.02  # m: the ball of a stand-in; its sticks are 0.6 of it
MAX_MESH_MB = 64
"""A mesh file larger than this is not read (a stand-in, with a warning naming the limit):
the conversion's time and memory grow with it (a 48 MB OBJ took 30 s and 2 GB)."""
MAX_LINK_VERTICES = 500_000
"""Vertices of one link's GLB after conversion: every page loads it (about 36 bytes each)."""
_GREY = (0.6, 0.6, 0.62, 1.0)
_OBJ_REFS = re.compile(rb"^\s*(?:mtllib|map_\w+)\s+(.+?)\s*$", re.M)
_DAE_REFS = re.compile(rb"<init_from>\s*([^<]+?)\s*</init_from>")


def _digest(path: Path) -> str:
    try:
        with path.open("rb") as file:  # streamed: a mesh is never held whole for its hash
            return hashlib.file_digest(file, "sha256").hexdigest()
    except OSError as exc:  # converted to a stand-in; the key still names the file's state
        return f"unreadable: {exc.strerror}"


def _too_large(path: Path) -> str | None:
    """Why ``path`` is not read (over ``MAX_MESH_MB``), or None."""
    try:
        size = path.stat().st_size
    except OSError:
        return None
    if size <= MAX_MESH_MB * 1024 * 1024:
        return None
    return f"it is {size / 1e6:.0f} MB, over linkview's limit of {MAX_MESH_MB} MB for a mesh file"


def _dependencies(path: Path) -> list[Path]:
    """Files a mesh names that change its looks: OBJ material libraries and textures, DAE images."""
    if _too_large(path):
        return []  # never read: drawn as a stand-in
    try:
        data = path.read_bytes()
    except OSError:
        return []
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


def _dielectric(material: Any) -> Any:
    """``material`` as glTF PBR, not a metal unless it says so.

    OBJ (MTL) and COLLADA materials have no metalness, and glTF's default is
    1: a full metal, which looks black without an environment to reflect.
    """
    pbr = material.to_pbr() if hasattr(material, "to_pbr") else material
    if getattr(pbr, "metallicFactor", 0.0) is None:
        pbr.metallicFactor = 0.0
    return pbr


def _finish(mesh: Any, rgba: tuple[float, float, float, float] | None) -> Any:
    """``mesh`` with crisp edges and a material, unless it brings textures or per-vertex colours."""
    visual = mesh.visual
    if _textured(visual):
        visual.material = _dielectric(visual.material)
        return mesh
    if visual.kind in ("vertex", "face"):
        return mesh
    material = _dielectric(visual.material) if visual.kind == "texture" else _material(rgba)
    mesh.merge_vertices()
    shaded = tm.graph.smooth_shade(mesh, angle=SHARP, facet_minarea=None)
    shaded.metadata.clear()
    shaded.visual = tm.visual.TextureVisuals(material=material)
    return shaded


def _collada_unit(path: Path) -> float:
    """Metres per unit of a COLLADA file (``<asset><unit meter>``), 1 if not given.

    Read as a stream that stops at the end of ``<asset>``, the file's first
    element: exported meshes hold single text nodes of tens of megabytes, past
    what lxml parses whole by default, and the geometry is trimesh's to read.
    """
    with path.open("rb") as file:  # closed however early the loop stops
        events = etree.iterparse(
            file, events=("end",), huge_tree=True, resolve_entities=False, no_network=True
        )  # the same guards as _safe_xml
        for _, el in events:
            tag = etree.QName(el).localname
            if tag == "unit" and etree.QName(el.getparent()).localname == "asset":
                return float(el.get("meter", "1"))
            if tag == "asset":
                break
    return 1.0


def _safe_xml() -> Any:
    return etree.XMLParser(huge_tree=True, resolve_entities=False, no_network=True)


def _collada_without_materials(path: Path) -> Any:
    """The scene of a COLLADA file read with its material bindings cut away.

    pycollada drops a whole node when one material it binds is broken (an
    effect naming a texture surface that is not there, as Blender 2.79 wrote
    some), so the link would have no shape at all; its shape matters more.
    """
    root = etree.parse(str(path), _safe_xml()).getroot()
    for bind in root.findall(".//{*}bind_material"):
        bind.getparent().remove(bind)
    return tm.load(io.BytesIO(etree.tostring(root)), file_type="dae", force="scene")


def _load_scene(path: Path) -> Any:
    scene = tm.load(path, force="scene")
    if not scene.geometry and path.suffix.lower() == ".dae":
        scene = _collada_without_materials(path)
    return scene


def _mesh_file(visual: Visual, geometry: MeshGeometry) -> list[Any]:
    too_large = _too_large(geometry.path)
    if too_large:
        raise ValueError(too_large)
    scene = _load_scene(geometry.path)
    unit = _collada_unit(geometry.path) if geometry.path.suffix.lower() == ".dae" else 1.0
    scale = np.diag([*(unit * s for s in geometry.scale), 1.0])
    parts = []
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        part = scene.geometry[name].copy()
        if not hasattr(part, "faces"):  # points or lines in the file: nothing to shade
            continue
        part.apply_transform(visual.origin @ scale @ transform)
        parts.append(part)
    if not parts:
        raise ValueError("it holds no triangles")
    return parts


def _stand_in(visual: Visual, geometry: StandInGeometry) -> list[Any]:
    parts = [tm.creation.icosphere(subdivisions=2, radius=STAND_IN_RADIUS)]
    for end in geometry.ends:
        segment = [[0.0, 0.0, 0.0], list(end)]
        parts.append(
            tm.creation.cylinder(STAND_IN_RADIUS * 0.6, segment=segment, sections=SECTIONS // 2)
        )
    return [part.apply_transform(visual.origin) for part in parts]


def _meshes(visual: Visual) -> list[Any]:
    """The visual's geometry in the link frame, finished."""
    geometry = visual.geometry
    if isinstance(geometry, MeshGeometry):
        parts = _mesh_file(visual, geometry)
    elif isinstance(geometry, StandInGeometry):
        parts = _stand_in(visual, geometry)
    elif isinstance(geometry, CapsuleGeometry):
        capsule = tm.creation.capsule(
            height=geometry.length, radius=geometry.radius, count=[SECTIONS, SECTIONS // 2]
        )
        parts = [capsule.apply_transform(visual.origin)]
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


def convert_link(
    link: str, visuals: tuple[Visual, ...], stand_in: Visual | None = None
) -> tuple[bytes, list[str]]:
    """One binary glTF of ``link``'s visuals, its scene origin the link frame (m, Z up).

    A mesh file that cannot be read is replaced by ``stand_in`` (default: a
    ball on the link frame), with a warning; returns the GLB and the warnings.
    """
    scene = tm.Scene()
    warnings = []
    k = 0
    vertices = 0
    for visual in visuals:
        try:
            meshes = _meshes(visual)
            count = sum(len(mesh.vertices) for mesh in meshes)
            if vertices + count > MAX_LINK_VERTICES:
                raise ValueError(
                    f"the link's meshes have more than {MAX_LINK_VERTICES} vertices after "
                    "conversion, linkview's limit per link"
                )
        except Exception as exc:  # trimesh and pycollada raise many kinds on a broken file
            if not isinstance(visual.geometry, MeshGeometry):
                raise
            geometry = visual.geometry
            warnings.append(
                f"link {link!r}: mesh {geometry.uri or str(geometry.path)!r} ({geometry.path}) "
                f"cannot be read ({exc}); drawn as a stand-in"
            )
            fallback = stand_in or Visual(np.eye(4), StandInGeometry(), None)
            meshes = _meshes(Visual(fallback.origin, fallback.geometry, visual.rgba))
        vertices += sum(len(mesh.vertices) for mesh in meshes)
        for mesh in meshes:
            scene.add_geometry(mesh, node_name=f"{link}_{k}", geom_name=f"{link}_{k}")
            k += 1
    return bytes(tm.exchange.gltf.export_glb(scene, include_normals=True)), warnings


@dataclass(frozen=True)
class LinkMeshes:
    """A robot's GLB file per link that has visuals, and what could not be converted."""

    files: dict[str, Path]
    warnings: tuple[str, ...] = ()


def _write(path: Path, data: bytes) -> None:
    """Write through a temporary name and rename, so a reader never sees half a file."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    with os.fdopen(fd, "wb") as f:
        f.write(data)
    os.replace(tmp, path)


def link_meshes(robot: UrdfRobot, cache_dir: str | Path) -> LinkMeshes:
    """GLB file per link that has visuals, converted only if ``cache_dir`` lacks it.

    Files are named by ``mesh_key``; warnings of a conversion are kept in a
    ``.warnings.json`` beside its GLB.
    """
    cache = Path(cache_dir)
    cache.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    warnings: list[str] = []
    for link, visuals in robot.visuals.items():
        if not visuals:
            continue
        path = cache / f"{mesh_key(link, visuals)}.glb"
        notes = path.with_suffix(".warnings.json")
        if path.is_file():
            if notes.is_file():
                warnings += json.loads(notes.read_text(encoding="utf-8"))
        else:
            data, found = convert_link(link, visuals, robot.stand_in(link))
            if found:
                _write(notes, json.dumps(found).encode())
                warnings += found
            _write(path, data)
        files[link] = path
    return LinkMeshes(files, tuple(warnings))
