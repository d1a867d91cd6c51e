"""Kinematics from a cell file's ``kinematics`` table, one builder per family (mm, deg -> SI)."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..kinematics import DHChain, LBRiiwa, Type12, WorldModel, matrix_from_rpy
from ..kinematics._pose_vector import pose_vector_from_matrix
from ..sandbox import Confinement, Limits
from . import schema
from .axis_group import AxisGroupKinematics
from .robot import DEG, MM, Array, Family, Kinematics

# WorldModel's stand-in for "no limit" (the MotionPlus Axis Group API: "practically infinite").
UNLIMITED = 1e300


class SpecError(ValueError):
    """A kinematics table that cannot be built; ``key`` is the path below ``kinematics``."""

    def __init__(self, key: str, reason: str) -> None:
        super().__init__(reason)
        self.key = key


@dataclass(frozen=True)
class Where:
    """Where a cell's files are: relative paths start at the cell file; meshes are cached.

    ``env`` is where a description's ``xacro_env`` variables are read from;
    ``limits`` bound the worker that expands it.
    """

    cell_dir: Path
    cache_dir: Path
    env: Mapping[str, str] = field(default_factory=dict, hash=False, compare=False)
    limits: Limits = Limits()

    def resolve(self, relative: str) -> Path:
        """A path from the cell file, relative to its folder."""
        return (self.cell_dir / Path(relative).expanduser()).resolve()


@dataclass(frozen=True)
class Built:
    """A kinematic family made from its table, with what the cell needs to know about it."""

    family: Family
    kinematics: Kinematics
    joint_names: tuple[str, ...]
    link_names: tuple[str, ...]
    limits: tuple[tuple[float, float] | None, ...]
    """Per joint, [lower, upper] in rad or m; None: unlimited."""
    linear: tuple[bool, ...]
    """Per joint, True for a prismatic (metres) joint."""
    tcp_is_last_link: bool
    meshes: tuple[Path | None, ...] = ()
    """Per link, a GLB the family brought along (URDF visuals); empty: none."""
    warnings: tuple[str, ...] = ()
    """What the description holds that cannot be shown as written (it still runs)."""


def pose_matrix(pose: schema.Pose) -> Array:
    """4x4 of a cell-file pose: ``xyz`` (mm), then fixed-axis roll, pitch, yaw (deg)."""
    matrix = np.eye(4)
    matrix[:3, :3] = matrix_from_rpy(np.radians(pose.rpy_deg))
    matrix[:3, 3] = np.asarray(pose.xyz) / 1000.0
    return matrix


def _limits_si(
    limits: Sequence[Sequence[float]] | None, n: int, factors: Sequence[float]
) -> tuple[tuple[float, float] | None, ...]:
    if limits is None:
        return (None,) * n
    if len(limits) != n:
        raise SpecError("limits", f"needs one [lower, upper] per joint ({n}), got {len(limits)}")
    out: list[tuple[float, float] | None] = []
    for i, ((lo, hi), factor) in enumerate(zip(limits, factors, strict=True)):
        if not lo < hi:
            raise SpecError(f"limits[{i}]", f"lower {lo:g} must be below upper {hi:g}")
        out.append((lo * factor, hi * factor))
    return tuple(out)


def _type12(spec: schema.Type12, where: Where) -> Built:
    kin = Type12(*(length / 1000.0 for length in (spec.L1, spec.L2, spec.L3, spec.L4, spec.L5)))
    return Built(
        family="type12",
        kinematics=kin,
        joint_names=("a0", "a1"),
        link_names=kin.link_names,
        limits=_limits_si(spec.limits, 2, [DEG, DEG]),
        linear=(False, False),
        tcp_is_last_link=False,
    )


def _dh(spec: schema.DH, where: Where) -> Built:
    n = len(spec.d)
    for key in ("a", "alpha_deg", "offset_deg"):
        values = getattr(spec, key)
        if values is not None and len(values) != n:
            raise SpecError(key, f"has {len(values)} entries; d has {n}")
    limits = _limits_si(spec.limits, n, [DEG] * n)
    lim = None if spec.limits is None else np.array(limits, dtype=np.float64)
    kin: DHChain
    if spec.solver == "iiwa":
        kin = _iiwa(spec, lim)
    else:
        kin = DHChain(
            d=np.asarray(spec.d) / 1000.0,
            a=np.asarray(spec.a) / 1000.0,
            alpha=np.radians(spec.alpha_deg),
            theta_offset=None if spec.offset_deg is None else np.radians(spec.offset_deg),
            convention=spec.convention,
            limits=lim,
        )
    return Built(
        family="dh",
        kinematics=kin,
        joint_names=tuple(f"a{i + 1}" for i in range(n)),
        link_names=tuple(f"link{i}" for i in range(n + 1)),
        limits=limits,
        linear=(False,) * n,
        tcp_is_last_link=True,
    )


def _iiwa(spec: schema.DH, limits: Array | None) -> LBRiiwa:
    """The LBR iiwa's analytic inverse, when the table is an iiwa's (else it would be wrong)."""
    d = np.asarray(spec.d) / 1000.0
    template = LBRiiwa(d[0], d[2], d[4], d[6], np.zeros((7, 2))) if len(d) == 7 else None
    offsets = np.zeros(7) if spec.offset_deg is None else np.radians(spec.offset_deg)
    if (
        template is None
        or spec.convention != "standard"
        or not np.allclose(d, template.d)
        or not np.allclose(np.asarray(spec.a) / 1000.0, template.a)
        or not np.allclose(np.radians(spec.alpha_deg), template.alpha)
        or not np.allclose(offsets, 0.0)
    ):
        raise SpecError(
            "solver",
            "'iiwa' needs an LBR iiwa table: 7 standard-DH joints, a = 0, "
            "alpha_deg = [-90, 90, 90, -90, -90, 90, 0], d = [d1, 0, d3, 0, d5, 0, d7], no offsets",
        )
    if limits is None:
        limits = np.tile([-np.pi, np.pi], (7, 1))
    return LBRiiwa(d[0], d[2], d[4], d[6], limits)


def _axis_group(spec: schema.AxisGroup, where: Where) -> Built:
    world = WorldModel()
    group = "group"
    try:
        world.axis_group_add(group, pose_vector_from_matrix(pose_matrix(spec.pose)))
        for i, axis in enumerate(spec.axes):
            factor = MM if axis.type == "linear" else DEG
            lo, hi = (-UNLIMITED, UNLIMITED) if axis.limits is None else axis.limits
            q_limits = [lo * factor, hi * factor] if axis.limits is not None else [lo, hi]
            try:
                world.axis_group_add_axis(
                    group,
                    axis.name,
                    axis.parent,
                    pose_vector_from_matrix(pose_matrix(axis.pose)),
                    0 if axis.type == "rotary" else 1,
                    axis.v_limit,
                    axis.a_limit,
                    q_limits=q_limits,
                    axis_index=axis.axis_index,
                )
            except ValueError as exc:
                raise SpecError(f"axes[{i}]", str(exc)) from exc
    except ValueError as exc:
        if isinstance(exc, SpecError):
            raise
        raise SpecError("pose", str(exc)) from exc
    kin = AxisGroupKinematics(world, group)
    ordered = [a["name"] for a in kin.params()["axes"]]  # axis-index order: the joint order
    by_name = {a.name: a for a in spec.axes}
    axes = [by_name[name] for name in ordered]
    factors = [MM if a.type == "linear" else DEG for a in axes]
    return Built(
        family="axis_group",
        kinematics=kin,
        joint_names=tuple(ordered),
        link_names=("base", *(a.link or a.name for a in axes)),
        limits=tuple(
            None if a.limits is None else (a.limits[0] * f, a.limits[1] * f)
            for a, f in zip(axes, factors, strict=True)
        ),
        linear=tuple(a.type == "linear" for a in axes),
        tcp_is_last_link=True,
    )


def _urdf(spec: schema.Urdf, where: Where) -> Built:
    # Imported here: yourdfpy and trimesh take ~80 MB and a second; cells without URDF skip them.
    from ..urdf import UrdfError, link_meshes, load_urdf

    packages = {name: where.resolve(folder) for name, folder in spec.packages.items()}
    # Only the variables the cell names, so no LINKVIEW_* setting or password is seen.
    env = {name: where.env[name] for name in spec.xacro_env if name in where.env}
    confinement = Confinement((where.cell_dir,), env, where.limits)
    try:
        robot = load_urdf(where.resolve(spec.file), packages, spec.tip, spec.args, confinement)
        glbs = link_meshes(robot, where.cache_dir)
    except UrdfError as exc:
        raise SpecError("file", str(exc)) from None
    except Exception as exc:  # trimesh raises many kinds on a broken mesh file
        raise SpecError("file", f"cannot convert its meshes to GLB: {exc!r}") from None
    chain = robot.chain
    return Built(
        family="urdf",
        kinematics=chain,
        joint_names=chain.joint_names,
        link_names=chain.link_names,
        limits=tuple(
            (float(lo), float(hi)) if np.isfinite(lo) and np.isfinite(hi) else None
            for lo, hi in chain.limits
        ),
        linear=tuple(unit == "m" for unit in chain.joint_units),
        tcp_is_last_link=False,
        meshes=tuple(glbs.files.get(link) for link in chain.link_names),
        warnings=robot.warnings + glbs.warnings,
    )


BUILDERS: dict[str, Callable[..., Built]] = {
    "type12": _type12,
    "dh": _dh,
    "axis_group": _axis_group,
    "urdf": _urdf,
}


def build(spec: schema.Kinematics, where: Where) -> Built:
    """The family a ``kinematics`` table describes; raises SpecError naming the bad key."""
    return BUILDERS[spec.type](spec, where)
