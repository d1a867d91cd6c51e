"""Write arm6's link meshes as small binary STL files.

Usage: ``python cells/examples/arm6/build_meshes.py``.

Each mesh is in its link frame (metres), as ``arm6_description/urdf/arm6.urdf``
uses it: joint housings are cylinders around the joint axis, arm segments are
capsules from one joint to the next. Colours come from the URDF's materials.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import trimesh

OUT = Path(__file__).resolve().parent / "arm6_description" / "meshes"
SECTIONS = 24  # segments around every round part: small files, still round on screen

# The joint offsets of arm6.urdf (UR5-like), metres.
D1, SHOULDER_Y, ELBOW_Y, A2, A3, D4, D5, D6 = (
    0.089159,
    0.13585,
    -0.1197,
    0.425,
    0.39225,
    0.093,
    0.09465,
    0.0823,
)


def cylinder(radius: float, z0: float, z1: float) -> trimesh.Trimesh:
    """Closed cylinder along z from ``z0`` to ``z1``."""
    return trimesh.creation.cylinder(
        radius,
        z1 - z0,
        sections=SECTIONS,
        transform=trimesh.transformations.translation_matrix([0, 0, (z0 + z1) / 2]),
    )


def capsule(radius: float, z0: float, z1: float) -> trimesh.Trimesh:
    """Capsule along z whose cylindrical part runs from ``z0`` to ``z1``."""
    mesh = trimesh.creation.capsule(height=z1 - z0, radius=radius, count=[SECTIONS, 8])
    mesh.apply_translation([0, 0, (z0 + z1) / 2 - mesh.centroid[2]])
    return mesh


def along_y(
    mesh: trimesh.Trimesh, at: tuple[float, float, float] = (0.0, 0.0, 0.0)
) -> trimesh.Trimesh:
    """``mesh`` (modelled along z) turned to lie along +y, then moved to ``at``."""
    turn = trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0])  # z -> y
    mesh.apply_transform(turn)
    mesh.apply_translation(at)
    return mesh


def concat(*meshes: trimesh.Trimesh) -> trimesh.Trimesh:
    return trimesh.util.concatenate(list(meshes))


def meshes() -> dict[str, trimesh.Trimesh]:
    """Every STL of arm6, by file stem."""
    return {
        "base": concat(cylinder(0.09, 0.0, 0.012), cylinder(0.065, 0.012, D1 - 0.004)),
        "shoulder": concat(
            cylinder(0.062, -0.002, 0.07),
            along_y(cylinder(0.062, 0.0, SHOULDER_Y + 0.06)),
        ),
        "upper_arm": capsule(0.046, 0.06, A2 - 0.06),
        "upper_arm_joints": concat(
            along_y(cylinder(0.062, -0.062, 0.062)),
            along_y(cylinder(0.052, -0.055, 0.06), (0.0, 0.0, A2)),
        ),
        "forearm": capsule(0.037, 0.05, A3 - 0.045),
        "forearm_joints": concat(
            along_y(cylinder(0.052, -0.06, 0.055)),
            along_y(cylinder(0.043, -0.05, 0.05), (0.0, 0.0, A3)),
        ),
        "wrist": concat(
            along_y(cylinder(0.043, -0.045, 0.045)),
            along_y(cylinder(0.032, 0.045, D4 - 0.04)),
        ),
        "flange": concat(
            along_y(cylinder(0.043, -0.045, D6 - 0.03)),
            along_y(cylinder(0.032, D6 - 0.03, D6)),
        ),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out", type=Path, default=OUT, help="output folder (default: %(default)s)"
    )
    out = parser.parse_args(argv).out
    out.mkdir(parents=True, exist_ok=True)
    for stem, mesh in meshes().items():
        path = out / f"{stem}.stl"
        path.write_bytes(trimesh.exchange.stl.export_stl(mesh))
        print(f"{path.stat().st_size:7d}  {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
