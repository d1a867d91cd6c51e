"""Build every link mesh into ``assets/<robot>/<link>.glb``: ``python assets/build_meshes.py``.

Each mesh is modelled in its link frame, as seed 000 (Figure 11) does in
Blender: the origin is the link's pivot, so the page only has to set the
object's position and quaternion from the frame's link pose. Units are metres,
Z up. The output is byte-identical on every run with the same trimesh and numpy
(fixed section counts, no timestamps or ids); ``tests/assets/test_meshes.py``
checks that a rebuild with whatever versions are installed draws the same
triangles with the same materials.

Link frames, in hello order:

* ``kin12`` (``L1``, ``L5``, ``L4``, ``L2``): pivot at the origin, bar along +X.
  The mechanism is planar; the bars are stacked in Z (L5, L1, L4, L2 from the
  bottom) on a pedestal that is part of L1 (it is round, so it looks fixed).
* ``iiwa7`` (``link0`` .. ``link7``): standard DH frame I. Joint I+1 turns
  about frame I's Z, and frame I+1's origin is d_{I+1} along it.
* ``positioner`` (``base``, ``tilt``, ``table``): tilt axis along base +X at
  z = 0.45; the tilt frame is the base turned +90 degrees about Y and placed on
  that axis; the table surface is its z = 0.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

import trimesh
from _shapes import (
    at,
    bar,
    box,
    concat,
    cylinder,
    finish,
    material,
    moved,
    rot,
    rounded_cylinder,
    tube,
)
from trimesh.visual.material import PBRMaterial

Part = tuple[str, trimesh.Trimesh, PBRMaterial]
"""(node name, geometry in the link frame, material)."""

DARK = material("dark_steel", (0.16, 0.17, 0.19), metallic=0.6, roughness=0.4)
GREY = material("grey", (0.38, 0.40, 0.44), metallic=0.2, roughness=0.6)

# -- kin12: five-bar, seed 000 (lengths in metres) --------------------------------
KIN12_BLUE = material("kin12_blue", (0.16, 0.42, 0.80), metallic=0.25, roughness=0.45)
BAR_HALF_WIDTH = 0.014
BAR_THICKNESS = 0.012
LAYER_GAP = 0.002
PEDESTAL_TOP = 0.040
HOLE = 0.0062
PIN = 0.0055
PIN_HEAD = 0.0095
HEAD_HEIGHT = 0.0015


def _layer(index: int) -> tuple[float, float]:
    """Bottom and top z of bar layer ``index`` (0 = lowest: L5, L1, L4, L2)."""
    z0 = PEDESTAL_TOP + LAYER_GAP + index * (BAR_THICKNESS + LAYER_GAP)
    return z0, z0 + BAR_THICKNESS


def _pin(name: str, x: float, from_layer: int, to_layer: int) -> Part:
    """Pin at ``x`` from the bottom of ``from_layer`` up through ``to_layer``, with a head."""
    z0 = _layer(from_layer)[0]
    top = _layer(to_layer)[1]
    mesh = concat(
        moved(cylinder(PIN, z0, top), at(x)),
        moved(cylinder(PIN_HEAD, top, top + HEAD_HEIGHT), at(x)),
    )
    return name, mesh, DARK


def _bar(name: str, stations: list[tuple[float, float]], layer: int) -> Part:
    return name, bar(stations, BAR_HALF_WIDTH, *_layer(layer)), KIN12_BLUE


def kin12() -> dict[str, list[Part]]:
    """Links L1, L5, L4, L2 of the Type 12 five-bar (L1..L5 = 0.2, 0.15, 0.1, 0.2, 0.1 m)."""
    l1, l2, l3, l4, l5 = 0.2, 0.15, 0.1, 0.2, 0.1
    pedestal = concat(
        rounded_cylinder(0.055, 0.0, 0.010, 0.003),
        cylinder(0.032, 0.010, PEDESTAL_TOP),
    )
    # The stylus hangs from L2's far end down to the TCP plane (base z = 0).
    stylus = concat(
        moved(cylinder(0.004, 0.006, _layer(3)[0]), at(l2)),
        moved(trimesh.creation.cone(0.004, 0.006, sections=32), at(l2)),
    )
    return {
        "L1": [
            _bar("L1_bar", [(0.0, HOLE), (l1, HOLE)], 1),
            _pin("L1_pin_O", 0.0, 0, 1),
            ("L1_pedestal", pedestal, GREY),
        ],
        "L5": [_bar("L5_bar", [(0.0, HOLE), (l5, HOLE)], 0)],
        "L4": [
            _bar("L4_bar", [(0.0, HOLE), (l4, HOLE)], 2),
            _pin("L4_pin_W", 0.0, 0, 2),
        ],
        "L2": [
            _bar("L2_bar", [(0.0, HOLE), (l3, HOLE), (l2, 0.0045)], 3),
            _pin("L2_pin_T", 0.0, 1, 3),
            _pin("L2_pin_E", l3, 2, 3),
            ("L2_stylus", stylus, DARK),
        ],
    }


# -- iiwa7: KUKA LBR iiwa 7 R800, standard DH -------------------------------------
IIWA_ORANGE = material("iiwa_orange", (0.96, 0.47, 0.10), metallic=0.05, roughness=0.42)
IIWA_SILVER = material("iiwa_silver", (0.80, 0.81, 0.83), metallic=0.3, roughness=0.35)
IIWA_D = (0.34, 0.0, 0.40, 0.0, 0.40, 0.0, 0.126)
HOUSING_RADIUS = 0.06
HOUSING_HALF_LENGTH = 0.075
TUBE_RADIUS = 0.05


def _housing(i: int) -> list[Part]:
    """Joint I+1's housing around frame I's Z axis, with dark bearing rings at both ends."""
    h = HOUSING_HALF_LENGTH
    body = rounded_cylinder(HOUSING_RADIUS, -h + 0.008, h - 0.008, 0.02)
    rings = concat(
        tube(0.035, HOUSING_RADIUS - 0.012, -h, -h + 0.008),
        tube(0.035, HOUSING_RADIUS - 0.012, h - 0.008, h),
    )
    return [(f"link{i}_housing", body, IIWA_ORANGE), (f"link{i}_bearing", rings, DARK)]


def iiwa7() -> dict[str, list[Part]]:
    """link0..link7, each in its DH frame (frame 0 = base, frame 7 = flange)."""
    d1 = IIWA_D[0]
    link0 = [
        ("link0_foot", rounded_cylinder(0.11, 0.0, 0.03, 0.008), GREY),
        ("link0_column", rounded_cylinder(0.068, 0.02, d1, 0.012), IIWA_SILVER),
    ]
    links: dict[str, list[Part]] = {"link0": link0}
    for i in range(1, 7):
        parts = _housing(i)
        d_next = IIWA_D[i]
        if d_next > 0.0:
            # Ends at the next frame's origin, inside the next link's housing.
            shaft = rounded_cylinder(TUBE_RADIUS, 0.0, d_next, 0.01)
            parts.append((f"link{i}_tube", shaft, IIWA_SILVER))
        links[f"link{i}"] = parts
    flange = cylinder(0.04, -0.01, 0.0)
    dowel = moved(cylinder(0.004, -0.002, 0.004, sections=16), at(0.028))
    links["link7"] = [("link7_flange", flange, DARK), ("link7_dowel", dowel, IIWA_ORANGE)]
    return links


# -- positioner: 2-axis tilt/rotate table -------------------------------------------
POS_BASE = material("positioner_base", (0.27, 0.30, 0.35), metallic=0.2, roughness=0.6)
POS_TEAL = material("positioner_teal", (0.05, 0.50, 0.46), metallic=0.15, roughness=0.45)
POS_TABLE = material("positioner_table", (0.78, 0.80, 0.82), metallic=0.4, roughness=0.35)
POS_MARK = material("positioner_mark", (0.90, 0.16, 0.12), metallic=0.0, roughness=0.5)
TILT_Z = 0.45
TABLE_RADIUS = 0.25


def _along_x(mesh: trimesh.Trimesh, z: float) -> trimesh.Trimesh:
    """A Z-axis solid laid along base +X (its z becomes x) and lifted to height ``z``."""
    return moved(mesh, at(z=z) @ rot("y", 90.0))


def positioner() -> dict[str, list[Part]]:
    """Links base, tilt and table of a tilt/rotate positioner."""
    uprights = []
    for side in (-1.0, 1.0):
        uprights += [
            box(side * 0.35 - 0.03, side * 0.35 + 0.03, -0.08, 0.08, 0.03, TILT_Z),
            _along_x(cylinder(0.08, side * 0.35 - 0.03, side * 0.35 + 0.03), TILT_Z),
        ]
    base = [
        ("base_plate", box(-0.46, 0.46, -0.26, 0.26, 0.0, 0.03), POS_BASE),
        ("base_uprights", concat(*uprights), POS_BASE),
        (
            "base_bearings",
            concat(
                _along_x(cylinder(0.05, 0.38, 0.40), TILT_Z),
                _along_x(cylinder(0.05, -0.40, -0.38), TILT_Z),
            ),
            DARK,
        ),
        ("base_motor", _along_x(rounded_cylinder(0.055, 0.40, 0.53, 0.01), TILT_Z), GREY),
    ]

    # Tilt frame: +Z along the tilt axis (base +X), -X up (base +Z) at zero tilt.
    arms = []
    for side in (-1.0, 1.0):
        z0, z1 = sorted((side * 0.27, side * 0.30))
        arms += [box(-0.075, 0.0, -0.10, 0.10, z0, z1), cylinder(0.10, z0, z1)]
    tilt = [
        ("tilt_plate", box(-0.075, -0.045, -0.27, 0.27, -0.30, 0.30), POS_TEAL),
        ("tilt_arms", concat(*arms), POS_TEAL),
        (
            "tilt_trunnions",
            concat(cylinder(0.035, 0.30, 0.32), cylinder(0.035, -0.32, -0.30)),
            DARK,
        ),
        ("tilt_drive", moved(rounded_cylinder(0.07, -0.045, 0.05, 0.012), rot("y", 90.0)), GREY),
    ]

    slots = []
    for k in range(6):
        slot = box(0.055, 0.225, -0.007, 0.007, -0.001, 0.0015)
        slots.append(moved(slot, rot("z", 60.0 * k)))
    table = [
        ("table_disc", rounded_cylinder(TABLE_RADIUS, -0.02, 0.0, 0.004), POS_TABLE),
        ("table_slots", concat(*slots, tube(0.02, 0.035, -0.001, 0.0015)), DARK),
        (
            "table_mark",
            moved(cylinder(0.012, -0.001, 0.006, sections=32), at(0.235 - 0.012)),
            POS_MARK,
        ),
    ]
    return {"base": base, "tilt": tilt, "table": table}


ROBOTS: dict[str, Callable[[], dict[str, list[Part]]]] = {
    "kin12": kin12,
    "iiwa7": iiwa7,
    "positioner": positioner,
}


def glb(parts: list[Part]) -> bytes:
    """One binary glTF whose scene origin is the link frame."""
    scene = trimesh.Scene()
    for name, mesh, mat in parts:
        scene.add_geometry(finish(mesh, mat), node_name=name, geom_name=name)
    return trimesh.exchange.gltf.export_glb(scene, include_normals=True)


def build(out_dir: Path) -> list[Path]:
    """Write every link mesh under ``out_dir`` and return the paths written."""
    written = []
    for robot, make in ROBOTS.items():
        for link, parts in make().items():
            path = out_dir / robot / f"{link}.glb"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(glb(parts))
            written.append(path)
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out",
        type=Path,
        default=Path(__file__).resolve().parent,
        help="output directory (default: assets/)",
    )
    args = parser.parse_args(argv)
    for path in build(args.out):
        print(f"{path.stat().st_size:8d}  {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
