"""Mesh primitives for the link meshes: numpy and trimesh only, no boolean ops.

Everything is in metres, Z up, built from fixed section counts so the output
is the same on every run. Shapes are returned un-shaded; ``finish`` splits
vertices at sharp edges (crisp rims, smooth round surfaces) and attaches a
PBR material.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import trimesh
from trimesh.visual.material import PBRMaterial

Array = npt.NDArray[np.float64]

SECTIONS = 64
"""Segments around every round feature (fixed, so the output never changes)."""

SHARP = np.radians(35.0)
"""Faces meeting at more than this angle get separate normals."""


def material(
    name: str, rgb: tuple[float, float, float], metallic: float = 0.1, roughness: float = 0.55
) -> PBRMaterial:
    """A named glTF metallic-roughness material with an sRGB base colour in [0, 1]."""
    # glTF colour factors are linear; the colours here are picked in sRGB.
    linear = [round(((c + 0.055) / 1.055) ** 2.4 if c > 0.04045 else c / 12.92, 6) for c in rgb]
    return PBRMaterial(
        name=name,
        baseColorFactor=[*linear, 1.0],
        metallicFactor=metallic,
        roughnessFactor=roughness,
        doubleSided=False,
    )


def finish(mesh: trimesh.Trimesh, mat: PBRMaterial) -> trimesh.Trimesh:
    """``mesh`` with vertices split at sharp edges and ``mat`` attached."""
    mesh.merge_vertices()
    mesh.fix_normals()
    shaded = trimesh.graph.smooth_shade(mesh, angle=SHARP, facet_minarea=None)
    shaded.metadata.clear()  # smooth_shade's bookkeeping would end up in the file's extras
    shaded.visual = trimesh.visual.TextureVisuals(material=mat)
    return shaded


def concat(*meshes: trimesh.Trimesh) -> trimesh.Trimesh:
    """One mesh made of several (no union: overlapping parts simply intersect)."""
    return trimesh.util.concatenate(list(meshes))


def moved(mesh: trimesh.Trimesh, matrix: Array) -> trimesh.Trimesh:
    """A copy of ``mesh`` transformed by the 4x4 ``matrix``."""
    out = mesh.copy()
    out.apply_transform(matrix)
    return out


def at(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> Array:
    """Translation matrix."""
    return trimesh.transformations.translation_matrix([x, y, z])


def rot(axis: str, degrees: float) -> Array:
    """Rotation matrix about a principal axis ``'x'``, ``'y'`` or ``'z'``."""
    vec = {"x": [1, 0, 0], "y": [0, 1, 0], "z": [0, 0, 1]}[axis]
    return trimesh.transformations.rotation_matrix(np.radians(degrees), vec)


def lathe(profile: list[tuple[float, float]], sections: int = SECTIONS) -> trimesh.Trimesh:
    """Solid of revolution about Z from a ``(radius, z)`` profile running bottom to top.

    The profile should start and end on the axis (radius 0) so the solid is closed.
    """
    return trimesh.creation.revolve(np.asarray(profile, dtype=np.float64), sections=sections)


def _arc(
    cx: float, cz: float, r: float, a0: float, a1: float, n: int = 8
) -> list[tuple[float, float]]:
    """Points of a profile arc centred at (cx, cz), from angle a0 to a1 (degrees)."""
    angles = np.radians(np.linspace(a0, a1, n + 1))
    return [(cx + r * float(np.cos(a)), cz + r * float(np.sin(a))) for a in angles]


def cylinder(radius: float, z0: float, z1: float, sections: int = SECTIONS) -> trimesh.Trimesh:
    """Closed cylinder about Z from ``z0`` to ``z1``."""
    return lathe([(0.0, z0), (radius, z0), (radius, z1), (0.0, z1)], sections)


def tube(
    r_in: float, r_out: float, z0: float, z1: float, sections: int = SECTIONS
) -> trimesh.Trimesh:
    """Hollow cylinder (a ring) about Z from ``z0`` to ``z1``."""
    profile = np.array([(r_in, z0), (r_out, z0), (r_out, z1), (r_in, z1), (r_in, z0)])
    return trimesh.creation.revolve(profile, sections=sections)


def rounded_cylinder(
    radius: float, z0: float, z1: float, fillet: float, sections: int = SECTIONS
) -> trimesh.Trimesh:
    """Cylinder about Z from ``z0`` to ``z1`` whose rims are rounded with radius ``fillet``."""
    profile = [(0.0, z0)]
    profile += _arc(radius - fillet, z0 + fillet, fillet, -90.0, 0.0)
    profile += _arc(radius - fillet, z1 - fillet, fillet, 0.0, 90.0)
    profile.append((0.0, z1))
    return lathe(profile, sections)


def box(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float) -> trimesh.Trimesh:
    """Axis-aligned box given by its bounds."""
    extents = [x1 - x0, y1 - y0, z1 - z0]
    centre = at((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)
    return trimesh.creation.box(extents=extents, transform=centre)


def _square_point(c: float, r: float, angle: float, round_side: bool) -> tuple[float, float]:
    """Where the ray at ``angle`` from station (c, 0) leaves its cell of half-size ``r``.

    The cell is a square, or a half-disc on the side of a round bar end.
    """
    ca, sa = float(np.cos(angle)), float(np.sin(angle))
    scale = 1.0 if round_side else 1.0 / max(abs(ca), abs(sa))
    return c + r * ca * scale, r * sa * scale


def bar(
    stations: list[tuple[float, float]],
    half_width: float,
    z0: float,
    z1: float,
    sections: int = SECTIONS,
) -> trimesh.Trimesh:
    """A flat bar along +X with round ends and a hole (or none) at each station.

    ``stations`` are ``(x, hole_radius)`` sorted by x; radius 0 means solid. The
    first and last stations are the centres of the round ends. Stations must be
    at least ``2 * half_width`` apart. The plate is triangulated by hand (one
    quad ring per station, one strip between neighbours) and extruded from
    ``z0`` to ``z1``, so it is watertight without any boolean operation.
    """
    assert sections % 8 == 0, "corners of the station cells need samples at 45 degrees"
    r = half_width
    keys: dict[tuple[int, int], int] = {}
    verts: list[tuple[float, float]] = []

    def vid(p: tuple[float, float]) -> int:
        key = (round(p[0] * 1e9), round(p[1] * 1e9))
        if key not in keys:
            keys[key] = len(verts)
            verts.append(p)
        return keys[key]

    tris: list[tuple[int, int, int]] = []
    angles = 2.0 * np.pi * np.arange(sections) / sections
    last = len(stations) - 1
    for k, (c, hole) in enumerate(stations):
        outer = []
        for a in angles:
            ca = float(np.cos(a))
            round_side = (k == 0 and ca < -1e-12) or (k == last and ca > 1e-12)
            outer.append(vid(_square_point(c, r, float(a), round_side)))
        if hole > 0.0:
            inner = [vid((c + hole * float(np.cos(a)), hole * float(np.sin(a)))) for a in angles]
            for j in range(sections):
                n = (j + 1) % sections
                tris += [(inner[j], outer[j], outer[n]), (inner[j], outer[n], inner[n])]
        else:
            centre = vid((c, 0.0))
            tris += [(centre, outer[j], outer[(j + 1) % sections]) for j in range(sections)]

    # Strips between neighbouring cells: the right edge of cell k and the left
    # edge of cell k+1 are sampled at the same heights y = r * tan(angle).
    quarter = sections // 8
    for (c0, _), (c1, _) in zip(stations[:-1], stations[1:], strict=True):
        ys = [r * float(np.tan(a)) for a in angles[: quarter + 1]]
        ys = sorted({round(y, 12) for y in ys} | {round(-y, 12) for y in ys})
        left = [vid((c0 + r, y)) for y in ys]
        right = [vid((c1 - r, y)) for y in ys]
        for j in range(len(ys) - 1):
            tris += [(left[j], right[j], right[j + 1]), (left[j], right[j + 1], left[j + 1])]
    return _extrude(np.asarray(verts), np.asarray(tris), z0, z1)


def _extrude(v2: Array, f2: npt.NDArray[np.int64], z0: float, z1: float) -> trimesh.Trimesh:
    """Prism from a counter-clockwise planar triangulation: caps plus walls on its boundary."""
    n = len(v2)
    vertices = np.vstack(
        [np.column_stack([v2, np.full(n, z0)]), np.column_stack([v2, np.full(n, z1)])]
    )
    edges = np.vstack([f2[:, [0, 1]], f2[:, [1, 2]], f2[:, [2, 0]]])
    undirected = np.sort(edges, axis=1)
    _, inverse, counts = np.unique(undirected, axis=0, return_inverse=True, return_counts=True)
    boundary = edges[counts[inverse.ravel()] == 1]
    a, b = boundary[:, 0], boundary[:, 1]
    walls = np.vstack([np.column_stack([a, b, b + n]), np.column_stack([a, b + n, a + n])])
    faces = np.vstack([f2[:, ::-1], f2 + n, walls])
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
