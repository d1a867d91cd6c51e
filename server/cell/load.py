"""Read a TOML cell file into SI robots and data sources; every mistake names its key.

``load_cell`` validates the file against ``server.cell.schema`` (unknown keys,
wrong units, ...), then checks what a schema cannot: names that must be
unique, sources that must exist, joint counts against the kinematics, files
(URDF, meshes, CA) that must be there, and password variables that must be
set. All problems are gathered into one CellError, one line each:
``<file>: <key path>: <reason>``, e.g. ``robot[2] "arm".joints[3].unit``; a
mistake does not hide the others (``server.cell._validate``).
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..ctrlx import check_base_url, client_ssl
from ..kinematics import pose7_from_matrix
from ..mqtt.nodes import check_mqtt_url, parse_node
from ..opcua import check_node as check_opcua_node
from ..opcua import check_opcua_url, load_certificates
from ..protocol import RobotInfo
from ..rtde.wire import check_rtde_url, parse_key, register_key
from ..sandbox import Limits
from ..text import plural, printable
from . import schema
from ._validate import Validated, validate
from .families import Built, SpecError, Where, build, pose_matrix
from .limits import MAX_FILE_BYTES, file_problem, node_problems, shape_problems
from .mesh_files import glb_problem
from .placeholder import missing_description, placeholder
from .robot import Joint, Robot
from .shown import relative_paths

DEFAULT_COMMAND_NODE = "motion/grp/{robot}/cmd/pos-abs"


@dataclass(frozen=True)
class KindRules:
    """What the loader checks of a source of one kind (``schema.SOURCE_TYPES``)."""

    check_url: Callable[[str], object]
    """Raises ValueError for a ``url`` this kind cannot follow."""
    password_required: bool = False
    """A ``url`` needs ``password_env`` (else the login is anonymous, where the kind has one)."""
    default_password: str = ""
    check_node: Callable[[str], object] | None = None
    """Raises ValueError for a node key this kind cannot read (None: any non-empty string)."""
    default_unit: schema.Unit | None = None
    """A joint's unit where the cell leaves it out (None: the schema's, degrees)."""
    unit_from_device: bool = False
    """A joint without ``unit`` takes its node's own: deg (rotary) or mm (linear), converted
    by the connector."""
    check_source: (
        Callable[[schema.SourceBase, Callable[[str], Path]], list[tuple[str, str]]] | None
    ) = None
    """Problems with the kind's own keys, ``(key, reason)``; paths resolved from the cell."""


def _check_opcua(spec: schema.SourceBase, resolve: Callable[[str], Path]) -> list[tuple[str, str]]:
    """An OPC UA source's login and certificate keys."""
    problems: list[tuple[str, str]] = []
    if not isinstance(spec, schema.OpcuaSource):
        return problems
    if spec.password_env is not None and spec.user is None:
        problems.append(("user", "required with password_env (else the session is anonymous)"))
    if spec.user is not None and spec.password_env is None:
        problems.append(("password_env", f"required with user {spec.user!r}"))
    if spec.server_certificate is not None:
        try:
            load_certificates(resolve(spec.server_certificate))
        except ValueError as exc:
            problems.append(("server_certificate", str(exc)))
    return problems


KIND_RULES: dict[str, KindRules] = {
    # A ctrlX CORE always needs a login; its factory password is the default.
    "ctrlx": KindRules(check_base_url, password_required=True, default_password="boschrexroth"),
    # RTDE has no login; its joint values are SI (rad, m), as are MotionPlus axis positions.
    "rtde": KindRules(check_rtde_url, check_node=parse_key, default_unit="rad"),
    # A broker may be anonymous; a user logs in with the password from password_env.
    "mqtt": KindRules(check_mqtt_url, check_node=parse_node),
    # OPC UA: anonymous unless the cell names a user; units from the nodes' EngineeringUnits.
    "opcua": KindRules(
        check_opcua_url,
        check_node=check_opcua_node,
        unit_from_device=True,
        check_source=_check_opcua,
    ),
}


class CellError(Exception):
    """A cell file that cannot be used; ``problems`` are ``(key path, reason)`` pairs."""

    def __init__(self, path: Path, problems: list[tuple[str, str]]) -> None:
        self.path = path
        self.problems = problems
        super().__init__("\n".join(f"{path}: {key}: {_line(reason)}" for key, reason in problems))


def unreadable(path: Path, exc: Exception) -> CellError:
    """The CellError for a file that raised what no check foresaw: one line, not a traceback
    (``check``, start-up and reload show it; the log keeps the traceback)."""
    return CellError(path, [("(file)", f"cannot be read: {type(exc).__name__}: {exc}")])


def _line(text: str) -> str:
    """A reason on one line, control characters escaped: one line per mistake, whatever a
    library's message (lxml, xacro) or the file's own text holds."""
    return printable(" / ".join(part.strip() for part in text.splitlines() if part.strip()))


@dataclass(frozen=True)
class Source:
    """A data source of the cell, ready to connect to (``url`` None: an embedded mock).

    ``type`` is its kind (``server.runtime.kinds``); ``options`` the kind's own keys
    as the cell file gave them (a ``schema.CtrlxSource``, ...), None for the defaults.
    """

    name: str
    url: str | None
    type: str = schema.DEFAULT_SOURCE_TYPE
    options: schema.SourceBase | None = None
    user: str = "boschrexroth"
    password: str = field(default="boschrexroth", repr=False)
    ca: Path | None = None
    insecure: bool = False
    period_s: float | None = None
    allow_commands: bool = False
    replay: Path | None = None
    """A recording played instead of reading a data layer (``url`` is then None)."""
    folder: Path | None = None
    """The cell file's folder: a kind's own relative paths start there (None: no file)."""


@dataclass(frozen=True)
class Cell:
    """Every robot and data source of one cell file."""

    path: Path | None
    sources: tuple[Source, ...]
    robots: tuple[Robot, ...]
    spec: schema.Cell | None = field(default=None, repr=False, compare=False)

    def robots_of(self, source: str) -> list[Robot]:
        """The robots driven by ``source``, in cell order."""
        return [r for r in self.robots if r.source == source]

    @property
    def folder(self) -> Path | None:
        """The cell file's folder, which texts for viewers name files relative to."""
        return None if self.path is None else self.path.parent

    def shown(self, text: str) -> str:
        """``text`` (a warning, an error) as viewers see it: paths relative to ``folder``."""
        return relative_paths(text, self.folder)

    def infos(
        self,
        commandable: Callable[[Robot], bool],
        hold_s: Callable[[Robot], float | None] = lambda _: None,
    ) -> list[RobotInfo]:
        """Every robot as announced in ``hello``, its warnings as viewers see them.

        ``hold_s``: how long its source's embedded mock holds a commanded pose (None: none).
        """
        infos = []
        for robot in self.robots:
            info = robot.info(commandable(robot), hold_s(robot))
            infos.append(info.model_copy(update={"warnings": list(map(self.shown, info.warnings))}))
        return infos


def default_cache_dir() -> Path:
    """Where converted URDF meshes are kept: ``$LINKVIEW_CACHE_DIR`` or the user's cache."""
    configured = os.environ.get("LINKVIEW_CACHE_DIR")
    if configured:
        return Path(configured)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "linkview"


def load_cell(
    path: Path,
    env: Mapping[str, str] | None = None,
    cache_dir: Path | None = None,
    text: str | None = None,
    stand_ins: bool | None = None,
) -> Cell:
    """The cell described by the TOML file at ``path``; raises CellError.

    ``env`` supplies passwords, the variables robots name in ``xacro_env`` and
    the ``LINKVIEW_XACRO_*`` limits (default: the environment); ``cache_dir`` keeps
    URDF meshes converted to GLB (default: ``default_cache_dir()``). ``text``:
    the file's contents as they would be (an edit not yet saved), read instead
    of the file; relative paths still start at ``path``'s folder. ``stand_ins``
    (None: where the file says ``allow_edits = true``): a robot whose URDF file
    is not there runs as a placeholder chain, with a warning, instead of
    failing the cell (its description is picked on the page;
    ``server.cell.placeholder``).
    """
    env = os.environ if env is None else env
    path = Path(path)
    raw = _parsed(path, text)
    too_big = shape_problems(raw)
    if too_big:  # before the schema: 100 000 robots would take minutes to validate
        raise CellError(path, too_big)
    try:
        limits = Limits.from_env(env)
    except ValueError as exc:
        raise CellError(path, [("(environment)", str(exc))]) from None
    where = Where(path.resolve().parent, cache_dir or default_cache_dir(), env, limits)
    if stand_ins is None:
        stand_ins = raw.get("allow_edits") is True
    return _Builder(path, validate(raw), env, where, stand_ins).cell()


def _parsed(path: Path, text: str | None = None) -> dict[str, Any]:
    """The TOML of ``path`` (or ``text``, its contents as edited), read no further than
    ``MAX_FILE_BYTES``; CellError otherwise."""
    try:
        if text is None:
            with path.open("rb") as file:
                data = file.read(MAX_FILE_BYTES + 1)
                size = max(len(data), os.fstat(file.fileno()).st_size)
        else:
            data = text.encode("utf-8")
            size = len(data)
        too_big = file_problem(size)
        if too_big is not None:
            raise CellError(path, [("(file)", too_big)])
        return tomllib.loads(data.decode("utf-8"))
    except FileNotFoundError:
        raise CellError(path, [("(file)", "no such file")]) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CellError(path, [("(file)", f"cannot read it: {exc}")]) from None
    except tomllib.TOMLDecodeError as exc:
        raise CellError(path, [("(file)", f"not valid TOML: {exc}")]) from None
    except RecursionError:  # tomllib parses nested arrays and tables by recursion
        raise CellError(path, [("(file)", "nests tables or arrays too deeply to read")]) from None


class _Builder:
    """Checks across keys and builds the SI objects, collecting every problem."""

    def __init__(
        self,
        path: Path,
        validated: Validated,
        env: Mapping[str, str],
        where: Where,
        stand_ins: bool = False,
    ) -> None:
        self.path = path
        self.stand_ins = stand_ins
        self.where = where
        self.valid = validated
        self.env = env
        self.problems: list[tuple[str, str]] = list(validated.problems)
        self._built: dict[str, Built] = {}
        """Kinematics by table: robots described alike share one (one batch per model, one
        load of each URDF; the families are immutable once built)."""

    def cell(self) -> Cell:
        names = self.valid.names
        self._kinds = {s.name: s.type for s in self.valid.sources.values()}
        self._unique("source", names["source"])
        self._unique("robot", names["robot"])
        sources = [self._source(i, s) for i, s in self.valid.sources.items()]
        known = set(names["source"].values())
        robots = []
        for i, robot in self.valid.robots.items():
            if robot.source not in known:
                self._report(
                    (
                        self._key("robot", i, ".source"),
                        f"no source named {robot.source!r} (sources: {', '.join(sorted(known))})",
                    )
                )
            built = self._robot(i, robot)
            if built is not None:
                robots.append(built)
        self._count_nodes(robots)
        if self.problems:
            raise CellError(self.path, sorted(self.problems, key=_file_order))
        assert self.valid.cell is not None  # no problems: the file passed the schema whole
        return Cell(self.path, tuple(s for s in sources if s), tuple(robots), self.valid.cell)

    def _count_nodes(self, robots: list[Robot]) -> None:
        """Every source's nodes, and the cell's, against ``limits``."""
        nodes: dict[str, set[str]] = {}
        for robot in robots:
            nodes.setdefault(robot.source, set()).update(robot.nodes, robot.setpoint_nodes)
        keys = {name: self._key("source", i) for i, name in self.valid.names["source"].items()}
        counts = [(keys.get(name, f"source {name!r}"), len(n)) for name, n in nodes.items()]
        self.problems += node_problems(counts, sum(len(n) for n in nodes.values()))

    def _key(self, section: str, index: int, rest: str = "") -> str:
        return self.valid.label(section, index) + rest

    def _report(self, problem: tuple[str, str]) -> None:
        if not self.valid.echoes(problem[0]):  # a key the schema refused: its default stood in
            self.problems.append(problem)

    def _unique(self, kind: str, names: dict[int, str]) -> None:
        first: dict[str, int] = {}
        for i, name in names.items():
            if name in first:
                self._report(
                    (
                        self._key(kind, i, ".name"),
                        f"duplicate name {name!r} (also {kind}[{first[name]}])",
                    )
                )
            first.setdefault(name, i)

    def _source(self, index: int, spec: schema.Source) -> Source | None:
        key = self._key("source", index)
        problems = len(self.problems)
        rules = KIND_RULES[spec.type]
        password = rules.default_password
        if spec.url is not None or spec.password_env is not None:
            if spec.password_env is None:
                if rules.password_required:
                    self._report(
                        (f"{key}.password_env", "required with a url (the password comes from it)")
                    )
            elif spec.password_env not in self.env:
                self._report(
                    (
                        f"{key}.password_env",
                        f"environment variable {spec.password_env} is not set",
                    )
                )
            else:
                password = self.env[spec.password_env]
        if spec.url is not None:
            try:
                rules.check_url(spec.url)
            except ValueError as exc:
                self._report((f"{key}.url", str(exc)))
        ca = None if spec.ca is None else self.where.resolve(spec.ca)
        if ca is not None:
            try:
                client_ssl(ca)
            except ValueError as exc:
                self._report((f"{key}.ca", str(exc)))
        if rules.check_source is not None:
            for name, reason in rules.check_source(spec, self.where.resolve):
                self._report((f"{key}.{name}", reason))
        replay = None if spec.replay is None else self.where.resolve(spec.replay)
        if replay is not None and spec.url is not None:
            self._report((f"{key}.replay", "a source replays a recording or has a url"))
        elif replay is not None and not replay.is_file():
            self._report((f"{key}.replay", f"no such file: {replay}"))
        if len(self.problems) > problems:
            return None
        return Source(
            name=spec.name,
            url=spec.url,
            type=spec.type,
            options=spec,
            user=spec.user or "",
            password=password,
            ca=ca,
            insecure=spec.insecure,
            period_s=None if spec.period_ms is None else spec.period_ms / 1000.0,
            allow_commands=spec.allow_commands,
            replay=replay,
            folder=self.where.cell_dir,
        )

    def _robot(self, index: int, spec: schema.Robot) -> Robot | None:
        key = self._key("robot", index)
        if not self._no_secrets(key, spec.kinematics):
            return None
        missing = missing_description(spec, self.where) if self.stand_ins else None
        try:
            if missing is not None:
                built = placeholder(spec, self.where, missing)
            else:
                table = spec.kinematics.model_dump_json()
                if table not in self._built:
                    self._built[table] = build(spec.kinematics, self.where)
                built = self._built[table]
        except SpecError as exc:
            self._report((f"{key}.kinematics.{exc.key}", str(exc)))
            return None
        joints = self._joints(key, spec, built)
        found = self._meshes(key, spec, built)
        targets = self._targets(key, spec, built)
        if joints is None or found is None or targets is None:
            return None
        meshes, refused = found
        base = pose7_from_matrix(pose_matrix(spec.base))
        return Robot(
            name=spec.name,
            family=built.family,
            kinematics=built.kinematics,
            joints=joints,
            link_names=built.link_names,
            source=spec.source,
            base=tuple(float(x) for x in base),
            meshes=meshes,
            tcp_is_last_link=built.tcp_is_last_link,
            command_node=spec.command_node or DEFAULT_COMMAND_NODE.format(robot=spec.name),
            demo_targets=targets,
            warnings=built.warnings + refused,
        )

    def _no_secrets(self, key: str, kinematics: schema.Kinematics) -> bool:
        """False (reported) if a description would see a source's password variable."""
        if not isinstance(kinematics, schema.Urdf):
            return True
        secrets = {s.password_env for s in self.valid.sources.values() if s.password_env}
        for k, name in enumerate(kinematics.xacro_env):
            if name in secrets:
                self._report(
                    (
                        f"{key}.kinematics.xacro_env[{k}]",
                        f"{name} holds a source's password: a description never sees it",
                    )
                )
                return False
        return True

    def _joints(self, key: str, spec: schema.Robot, built: Built) -> tuple[Joint, ...] | None:
        n = len(built.joint_names)
        kind = self._kinds.get(spec.source, schema.DEFAULT_SOURCE_TYPE)
        entries = spec.joints or _default_joints(kind, n)
        if not entries:
            self._report((f"{key}.joints", "required: one entry per joint of the kinematics"))
            return None
        if len(entries) != n:
            names = ", ".join(built.joint_names)
            self._report(
                (
                    f"{key}.joints",
                    f"the {built.family} kinematics has {plural(n, 'joint')} ({names}); "
                    f"{len(entries)} given",
                )
            )
            return None
        named = [e.joint is not None for e in entries]
        order: list[int] | None = list(range(n))
        if any(named):
            order = self._joint_order(key, entries, built.joint_names)
        if order is None:
            return None
        joints: list[Joint] = [None] * n  # type: ignore[list-item]
        ok = True
        rules = KIND_RULES[kind]
        for k, (entry, slot) in enumerate(zip(entries, order, strict=True)):
            linear = built.linear[slot]
            node = self._node(f"{key}.joints[{k}]", entry, kind)
            setpoint = None if entry.setpoint is None else entry.setpoint.strip("/")
            if setpoint is not None and not self._checked(
                f"{key}.joints[{k}].setpoint", setpoint, rules
            ):
                ok = False
            if node is None:
                ok = False
                continue
            unit, from_device = entry.unit, False
            if rules.default_unit is not None and "unit" not in entry.model_fields_set:
                unit = rules.default_unit
            elif rules.unit_from_device and "unit" not in entry.model_fields_set:
                unit, from_device = ("mm" if linear else "deg"), True
            if linear != (unit in ("mm", "m")):
                motion, units = ("linear", "mm or m") if linear else ("rotary", "deg or rad")
                self._report(
                    (
                        f"{key}.joints[{k}].unit",
                        f"joint {built.joint_names[slot]!r} is {motion}: unit must be {units}, "
                        f"not {unit!r}",
                    )
                )
                ok = False
            if entry.scale == 0.0:
                self._report((f"{key}.joints[{k}].scale", "must not be 0"))
                ok = False
            joints[slot] = Joint(
                name=built.joint_names[slot],
                node=node,
                source_unit=unit,
                scale=entry.scale,
                offset=entry.offset,
                limits=built.limits[slot],
                setpoint=setpoint,
                unit_from_device=from_device,
            )
        with_setpoint = [entry.setpoint is not None for entry in entries]
        if any(with_setpoint) and not all(with_setpoint):
            k = with_setpoint.index(False)
            self._report(
                (f"{key}.joints[{k}].setpoint", "give every joint a setpoint node, or none")
            )
            ok = False
        return tuple(joints) if ok else None

    def _node(self, key: str, entry: schema.Joint, kind: str) -> str | None:
        """The joint's node key: ``node``, or on an RTDE source ``field``/``index``/``register``."""
        keys = {"node": entry.node, "field": entry.field, "register": entry.output_register}
        given = [name for name, value in keys.items() if value is not None]
        if len(given) != 1:
            says = " and ".join(given) if given else "none of them"
            what = "node, field (with index) or register" if kind == "rtde" else "node"
            self._report((key, f"give one of {what}, not {says}"))
            return None
        if entry.node is None and kind != "rtde":
            self._report((f"{key}.{given[0]}", "only for RTDE sources: give node"))
            return None
        if entry.index is not None and entry.field is None:
            self._report((f"{key}.index", 'goes with field (e.g. field = "actual_q")'))
            return None
        if entry.output_register is not None:
            node = register_key(entry.output_register)
        elif entry.field is not None:
            node = entry.field if entry.index is None else f"{entry.field}[{entry.index}]"
        else:
            assert entry.node is not None
            node = entry.node.strip("/")
        where = key + (".node" if entry.node is not None else f".{given[0]}")
        return node if self._checked(where, node, KIND_RULES[kind]) else None

    def _checked(self, key: str, node: str, rules: KindRules) -> bool:
        if rules.check_node is None:
            return True
        try:
            rules.check_node(node)
        except ValueError as exc:
            self._report((key, str(exc)))
            return False
        return True

    def _joint_order(
        self, key: str, entries: list[schema.Joint], names: tuple[str, ...]
    ) -> list[int] | None:
        order: list[int] = []
        for k, entry in enumerate(entries):
            if entry.joint is None:
                self._report((f"{key}.joints[{k}].joint", "name every joint or none of them"))
                return None
            if entry.joint not in names:
                self._report(
                    (
                        f"{key}.joints[{k}].joint",
                        f"no movable joint {entry.joint!r} (joints: {', '.join(names)})",
                    )
                )
                return None
            if names.index(entry.joint) in order:
                self._report((f"{key}.joints[{k}].joint", f"{entry.joint!r} given twice"))
                return None
            order.append(names.index(entry.joint))
        return order

    def _meshes(
        self, key: str, spec: schema.Robot, built: Built
    ) -> tuple[tuple[Path | None, ...], tuple[str, ...]] | None:
        """Per link its GLB (None: a stand-in), and why files of ``mesh_dir`` were refused."""
        if spec.mesh_dir is None:
            return built.meshes or (None,) * len(built.link_names), ()
        if built.meshes:
            self._report(
                (f"{key}.mesh_dir", "URDF robots take their meshes from the URDF's visuals")
            )
            return None
        folder = self.where.resolve(spec.mesh_dir)
        if not folder.is_dir():
            self._report((f"{key}.mesh_dir", f"no such folder: {folder}"))
            return None
        missing = [n for n in built.link_names if not (folder / f"{n}.glb").exists()]
        if missing:
            self._report(
                (
                    f"{key}.mesh_dir",
                    f"missing mesh for {'link' if len(missing) == 1 else 'links'} "
                    f"{', '.join(missing)}: expected "
                    + ", ".join(str(folder / f"{n}.glb") for n in missing),
                )
            )
            return None
        files: list[Path | None] = []
        refused: list[str] = []
        for name in built.link_names:
            path = folder / f"{name}.glb"
            problem = glb_problem(path, folder)
            if problem is not None:  # never served: the page draws a stand-in
                refused.append(f"mesh {path} {problem}; drawn as a stand-in")
            files.append(None if problem else path)
        return tuple(files), tuple(refused)

    def _targets(
        self, key: str, spec: schema.Robot, built: Built
    ) -> tuple[tuple[float, ...], ...] | None:
        if spec.demo_targets is None:
            return ()
        n = len(built.joint_names)
        for k, target in enumerate(spec.demo_targets):
            if len(target) != n:
                self._report((f"{key}.demo_targets[{k}]", f"needs {n} values, one per joint"))
                return None
        return tuple(tuple(t) for t in spec.demo_targets)


def _default_joints(kind: str, n: int) -> list[schema.Joint]:
    """A robot on an RTDE source without a joint list: UR's six joints on ``actual_q``."""
    if kind != "rtde":
        return []
    return [
        schema.Joint(field="actual_q", index=i, unit="rad", setpoint=f"target_q[{i}]")
        for i in range(6)
    ]


def _file_order(problem: tuple[str, str]) -> tuple[int, int]:
    """Problems of the same source or robot together, in the order of the file."""
    key = problem[0]
    for rank, section in enumerate(("source", "robot"), start=1):
        if key.startswith(f"{section}["):
            return rank, int(key[len(section) + 1 : key.index("]")])
    return 0, 0
