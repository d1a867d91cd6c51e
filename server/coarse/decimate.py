"""A link's GLB made coarse for the page's 2D view: few triangles, one flat colour per part.

The 2D view (static/js/view2d) fills every triangle with Canvas 2D on the CPU,
each frame, so the whole demo cell must come to a few thousand triangles. Each
part is welded first (a GLB splits vertices along sharp edges, which would tear
it open), then simplified:

- a closed manifold part (what CAD exports and the shipped meshes are) by
  manifold3d, to ``TOLERANCE`` of the link's size: edges shorter than that
  collapse, so the silhouette holds however few triangles are left. A feature
  thinner than that may collapse whole (a pin's 1.5 mm collar): where the part's
  bounds move by more than the tolerance, it is simplified again to half of it;
- any other part, and one still far above its share of ``LINK_FACES`` (its
  edges longer than the tolerance), by fast-simplification's quadric edge
  collapse (through trimesh) to that share. That may stall above the share or
  move a corner out of the part's bounds (a vertex at a quadric's optimum); then
  the part's convex hull (qhull through trimesh) is tried, then twice the
  share, and so on up to the whole part.

Textures, normals and UVs are dropped: the view shades each triangle flat, in its
part's colour (a texture's mean colour). Parts keep their names, transforms and
order, so the link frame stays the scene origin.
"""

from __future__ import annotations

import io
from typing import Any

import manifold3d
import numpy as np
import trimesh

# trimesh and manifold3d are only partly annotated; mypy --strict would flag every call.
tm: Any = trimesh
m3: Any = manifold3d

FORMAT = 2
"""Bump when the output below changes: it is part of every cache key."""
TOLERANCE = 0.01
"""How far (a share of the link's largest extent) a closed part's surface may move."""
HALVINGS = 4
"""Of the tolerance, for a part whose bounds moved; then the part stays whole."""
LINK_FACES = 480
"""Triangles per link, all its other parts together."""
MIN_PART_FACES = 16
"""A part keeps at least this many (or all it has): a bolt stays a shape, not a sliver."""
CLOSED_SHARES = 3
"""A closed part simplified to the tolerance may keep up to this many times its share."""
STALLED = 1.5
"""Decimation that ends above this many times a part's share has stalled."""
KEEP_BOUNDS = 0.01
"""A decimated part's bounds stay within this share of its size (at least KEEP_BOUNDS_M)."""
KEEP_BOUNDS_M = 0.001


class CoarseError(ValueError):
    """The GLB could not be read or holds no triangles."""


def _colour(part: Any) -> list[int]:
    """The part's colour as glTF's linear RGBA bytes: its material's, or its mean colour."""
    visual = part.visual
    material = getattr(visual, "material", None)
    source = material if material is not None else visual  # per-vertex or per-face colours
    colour = np.asarray(source.main_color, dtype=np.float64)
    return [int(c) for c in np.clip(np.round(colour[:4]), 0, 255)]


def _shares(faces: list[int], budget: int) -> list[int]:
    """Faces each part may keep: ``budget`` shared in proportion to their sizes."""
    total = max(sum(faces), 1)
    return [min(n, max(MIN_PART_FACES, round(budget * n / total))) for n in faces]


def _manifold(shape: Any, tolerance: float) -> Any | None:
    """``shape`` simplified to ``tolerance`` (m) in its bounds; None if it is no closed manifold."""
    mesh = m3.Mesh(
        vert_properties=np.asarray(shape.vertices, dtype=np.float32),
        tri_verts=np.asarray(shape.faces, dtype=np.uint32),
    )
    solid = m3.Manifold(mesh)
    if solid.status() != m3.Error.NoError or solid.is_empty():
        return None
    for _ in range(HALVINGS):
        out = solid.simplify(tolerance).to_mesh()
        vertices = np.asarray(out.vert_properties, dtype=np.float64)[:, :3]
        if np.allclose([vertices.min(axis=0), vertices.max(axis=0)], shape.bounds, atol=tolerance):
            return tm.Trimesh(vertices=vertices, faces=np.asarray(out.tri_verts), process=False)
        tolerance /= 2
    return shape


def _decimated(shape: Any, keep: int) -> Any:
    return shape.simplify_quadric_decimation(face_count=keep) if len(shape.faces) > keep else shape


def _budgeted(shape: Any, keep: int) -> Any:
    """``shape`` decimated to about ``keep`` faces within its bounds (else its hull, or more)."""
    bounds = shape.bounds
    slack = max(KEEP_BOUNDS_M, KEEP_BOUNDS * float(np.max(shape.extents)))
    hull = None
    while keep < len(shape.faces):
        for source in ("shape", "hull"):
            if source == "hull" and hull is None:
                hull = shape.convex_hull
            coarse = _decimated(shape if source == "shape" else hull, keep)
            small = len(coarse.faces) <= STALLED * keep
            if small and np.allclose(coarse.bounds, bounds, atol=slack):
                return coarse
        keep *= 2
    return shape


def _coarse_part(part: Any, tolerance: float, keep: int) -> Any:
    """``part`` (a Trimesh) welded and simplified, without visuals."""
    shape = tm.Trimesh(vertices=part.vertices, faces=part.faces, process=False)
    shape.merge_vertices(merge_tex=True, merge_norm=True)
    closed = _manifold(shape, tolerance)
    if closed is not None and len(closed.faces) <= CLOSED_SHARES * keep:
        return closed
    # Not closed, or far above its share (its edges longer than the tolerance): down to it.
    return _budgeted(shape if closed is None else closed, keep)


def coarse_glb(data: bytes, tolerance: float = TOLERANCE, link_faces: int = LINK_FACES) -> bytes:
    """A GLB of the same parts, placed as in ``data``, simplified (see the module's notes).

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
    size = tolerance * float(np.max(scene.extents))
    budgets = _shares([len(scene.geometry[name].faces) for _, _, name in nodes], link_faces)
    out = tm.Scene()
    for (node, transform, name), keep in zip(nodes, budgets, strict=True):
        part = scene.geometry[name]
        try:
            coarse = _coarse_part(part, size, keep)
        except Exception as exc:  # either library on a degenerate part, among others
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
