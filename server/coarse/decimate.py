"""A link's GLB made coarse for the page's 2D view: few triangles, one flat colour per part.

The 2D view (static/js/view2d) fills every triangle with Canvas 2D on the CPU,
each frame, so the whole demo cell must come to a few thousand triangles:
``LINK_FACES`` per link, shared among its parts by their size. Each part is
welded (a GLB splits vertices along sharp edges, which decimation would tear
open) and decimated by fast-simplification's quadric edge collapse (through
trimesh). Where that stalls above one and a half times a part's share (it keeps
the many-sided rings of lathed parts such as pins and tubes), the part's convex
hull (qhull through trimesh: the same silhouette for such parts) is decimated
instead. Textures, normals and UVs are dropped: the view shades each
triangle flat, in its part's colour (a texture's mean colour). Parts keep
their names, transforms and order, so the link frame stays the scene origin.
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np
import trimesh

# trimesh is only partly annotated, and mypy --strict would flag every call into it.
tm: Any = trimesh

FORMAT = 1
"""Bump when the output below changes: it is part of every cache key."""
LINK_FACES = 480
"""Triangles per link, all parts together: 15 links of the demo cell make some 3,600."""
MIN_PART_FACES = 16
"""A part keeps at least this many (or all it has): a bolt stays a shape, not a sliver."""
STALLED = 1.5
"""Decimation that ends above this many times a part's share has stalled."""


class CoarseError(ValueError):
    """The GLB could not be read or holds no triangles."""


def _colour(part: Any) -> list[int]:
    """The part's colour as glTF's linear RGBA bytes: its material's, or its mean colour."""
    visual = part.visual
    material = getattr(visual, "material", None)
    if material is not None:
        colour = np.asarray(material.main_color, dtype=np.float64)
    else:  # per-vertex or per-face colours
        colour = np.asarray(visual.main_color, dtype=np.float64)
    return [int(c) for c in np.clip(np.round(colour[:4]), 0, 255)]


def _shares(faces: list[int], budget: int) -> list[int]:
    """Faces each part may keep: ``budget`` shared in proportion to their sizes."""
    total = max(sum(faces), 1)
    return [min(n, max(MIN_PART_FACES, round(budget * n / total))) for n in faces]


def _decimated(shape: Any, keep: int) -> Any:
    return shape.simplify_quadric_decimation(face_count=keep) if len(shape.faces) > keep else shape


def _coarse_part(part: Any, keep: int) -> Any:
    """``part`` (a Trimesh) welded and decimated to about ``keep`` faces, without visuals."""
    shape = tm.Trimesh(vertices=part.vertices, faces=part.faces, process=False)
    shape.merge_vertices(merge_tex=True, merge_norm=True)
    coarse = _decimated(shape, keep)
    if len(coarse.faces) > STALLED * keep:
        hull = _decimated(shape.convex_hull, keep)
        if len(hull.faces) < len(coarse.faces):
            coarse = hull
    return coarse


def coarse_glb(data: bytes, link_faces: int = LINK_FACES) -> bytes:
    """A GLB of the same parts, placed as in ``data``, with about ``link_faces`` triangles.

    Each part has one PBR material of its original's colour (alpha kept).
    Raises CoarseError when ``data`` is not a GLB trimesh can read or has no triangles.
    """
    try:
        scene = tm.load(io.BytesIO(data), file_type="glb", force="scene")
    except Exception as exc:  # trimesh raises many kinds on a broken file
        raise CoarseError(f"cannot read it as a GLB ({exc})") from None
    nodes = [
        (node, *scene.graph[node])
        for node in scene.graph.nodes_geometry
        if hasattr(scene.geometry[scene.graph[node][1]], "faces")
    ]
    if not nodes:
        raise CoarseError("it holds no triangles")
    budgets = _shares([len(scene.geometry[name].faces) for _, _, name in nodes], link_faces)
    out = tm.Scene()
    for (node, transform, name), keep in zip(nodes, budgets, strict=True):
        part = scene.geometry[name]
        try:
            coarse = _coarse_part(part, keep)
        except Exception as exc:  # fast-simplification on a degenerate part, among others
            raise CoarseError(f"cannot simplify its part {name!r} ({exc})") from None
        r, g, b, a = _colour(part)
        coarse.visual = tm.visual.TextureVisuals(
            material=tm.visual.material.PBRMaterial(
                baseColorFactor=[r, g, b, a],
                metallicFactor=0.0,
                roughnessFactor=1.0,
                alphaMode="BLEND" if a < 255 else None,
            )
        )
        out.add_geometry(coarse, node_name=str(node), geom_name=str(name), transform=transform)
    return bytes(tm.exchange.gltf.export_glb(out, include_normals=False))
