"""The cell file's schema: what a TOML cell may say, as pydantic models (see docs/cell.md).

Units as people write them: lengths in millimetres, angles in degrees (keys
ending in ``_deg``); ``limits`` are degrees for rotary and millimetres for
linear joints. Joint values are in whatever unit their data-layer node
reports. ``server.cell.load`` turns a validated file into SI objects.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Discriminator, Field, Tag

from ..sizes import MAX_JOINTS

Unit = Literal["deg", "rad", "mm", "m"]
Name = Annotated[str, Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.\-]+$")]
Vec3 = Annotated[list[float], Field(min_length=3, max_length=3)]
Range = Annotated[list[float], Field(min_length=2, max_length=2)]
Finite = Annotated[float, Field(allow_inf_nan=False)]
RESERVED_ENV_PREFIX = "LINKVIEW_"


def _not_linkview(name: str) -> str:
    if name.upper().startswith(RESERVED_ENV_PREFIX):
        raise ValueError(f"{name} is linkview's own setting, never a description's")
    return name


EnvName = Annotated[
    str,
    Field(min_length=1, max_length=128, pattern=r"^[A-Za-z_][A-Za-z0-9_]*$"),
    AfterValidator(_not_linkview),
]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Pose(_Strict):
    """A placement: translation ``xyz`` (mm), then fixed-axis roll, pitch, yaw (deg)."""

    xyz: Vec3 = [0.0, 0.0, 0.0]
    rpy_deg: Vec3 = [0.0, 0.0, 0.0]


class SourceBase(_Strict):
    """What every kind of source has: a device at ``url``, or (no ``url``) an embedded mock."""

    name: Name
    url: str | None = None
    user: str = "boschrexroth"
    password_env: str | None = None
    """Environment variable holding the password; required with ``url``."""
    ca: str | None = None
    """PEM file of certificates to trust (relative paths: relative to the cell file)."""
    insecure: bool = False
    period_ms: Annotated[float, Field(gt=0.0, le=10_000.0)] | None = None
    """Sample period; default: the server's setting (20 ms)."""
    allow_commands: bool = False
    """Let the page move this source's robots (embedded mocks always may)."""
    replay: str | None = None
    """A recording (MCAP, docs/recording.md) played as this source's data, instead of a device."""


class CtrlxSource(SourceBase):
    """A ctrlX CORE's REST data layer (the default kind)."""

    type: Literal["ctrlx"] = "ctrlx"
    mode: Literal["subscribe", "poll", "get"] | None = None
    """As ``--mode``; default: the server's setting (subscribe)."""
    api: Literal["v2", "v1"] = "v2"


class RtdeSource(SourceBase):
    """A Universal Robots controller's RTDE interface: ``rtde://HOST[:PORT]`` (port 30004).

    RTDE has no login: ``user``, ``password_env`` and ``ca`` do not apply.
    """

    type: Literal["rtde"]
    frequency_hz: Annotated[float, Field(gt=0.0, le=500.0)] = 500.0
    """What the output recipe asks for (e-Series: up to 500 Hz; CB3: 125 Hz)."""


class MqttSource(SourceBase):
    """Values on an MQTT broker: ``mqtt://HOST[:PORT]`` (1883) or ``mqtts://`` (TLS, 8883)."""

    type: Literal["mqtt"]
    user: str | None = None  # type: ignore[assignment]
    """Username; none: an anonymous session (the password, if any, from ``password_env``)."""
    client_id: Annotated[str, Field(max_length=64)] | None = None
    """The MQTT client identifier; default: one the broker assigns."""


class OpcuaSource(SourceBase):
    """An OPC UA server: ``opc.tcp://HOST[:PORT][/PATH]`` (port 4840 by convention).

    Joints name NodeIds or browse paths (``server.opcua.nodes``); a joint without
    ``unit`` takes its node's EngineeringUnits. ``ca`` and ``insecure`` do not apply.
    """

    type: Literal["opcua"]
    user: str | None = None  # type: ignore[assignment]
    """Username, its password from ``password_env``; none: an anonymous session."""
    security: Literal["None", "Sign", "SignAndEncrypt"] = "None"
    """Basic256Sha256 signing, or signing and encryption; ``None``: neither."""
    server_certificate: str | None = None
    """The server's certificate to trust (DER or PEM; relative paths: the cell's folder)."""
    client_certificate: str = "linkview-opcua-client.der"
    """linkview's own certificate, made there at the first secure session (its key beside it,
    ``<name>.key.pem``); the server's administrator trusts it once."""


DEFAULT_SOURCE_TYPE = "ctrlx"


def _source_type(value: object) -> str:
    """A source's ``type``; a table without one is a ctrlX source."""
    if isinstance(value, dict):
        return str(value.get("type", DEFAULT_SOURCE_TYPE))
    return str(getattr(value, "type", DEFAULT_SOURCE_TYPE))


# One member per kind of source, tagged by its ``type`` (see server/runtime/kinds/).
Source = Annotated[
    Annotated[CtrlxSource, Tag("ctrlx")]
    | Annotated[RtdeSource, Tag("rtde")]
    | Annotated[MqttSource, Tag("mqtt")]
    | Annotated[OpcuaSource, Tag("opcua")],
    Discriminator(_source_type),
]
SOURCE_TYPES = ("ctrlx", "rtde", "mqtt", "opcua")


class Joint(_Strict):
    """A joint's node; SI value = (value x scale + offset) converted from ``unit``.

    ``unit`` left out: degrees (RTDE: radians; OPC UA: the node's own EngineeringUnits,
    delivered in degrees for rotary joints, millimetres for linear ones).
    """

    # ``register`` is an attribute of pydantic's models: the key is an alias.
    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)

    node: Annotated[str, Field(min_length=1)] | None = None
    """The node key (a data-layer path, ``actual_q[2]``, ``topic#/pointer``); or, on an RTDE
    source, ``field`` (and ``index``) or ``register`` instead."""
    field: Annotated[str, Field(min_length=1)] | None = None
    """RTDE: an output field: ``actual_q`` (with ``index``), ``output_double_register_24``."""
    index: Annotated[int, Field(ge=0, le=5)] | None = None
    """RTDE: which value of a vector ``field`` (0 to 5)."""
    output_register: Annotated[int | None, Field(alias="register", ge=0, le=255)] = None
    """``register`` (RTDE): ``output_double_register_<register>``, where a URScript program
    copies an external axis position (docs/cell.md)."""
    unit: Unit = "deg"
    scale: Finite = 1.0
    offset: Finite = 0.0
    joint: str | None = None
    """The kinematics' joint this entry drives (URDF joint name); default: by position."""
    setpoint: Annotated[str, Field(min_length=1)] | None = None
    """Node of the joint's setpoint (e.g. ``.../state/values/ipo/pos``), same unit and mapping."""


class Type12(_Strict):
    """The IndraMotion MLC kinematic Type 12 (a five-bar mechanism); link lengths in mm."""

    type: Literal["type12"]
    L1: Annotated[float, Field(gt=0.0)] = 200.0
    L2: Annotated[float, Field(gt=0.0)] = 150.0
    L3: Annotated[float, Field(gt=0.0)] = 100.0
    L4: Annotated[float, Field(gt=0.0)] = 200.0
    L5: Annotated[float, Field(gt=0.0)] = 100.0
    limits: list[Range] | None = None
    """Per joint [lower, upper] in degrees."""


class DH(_Strict):
    """A revolute Denavit-Hartenberg chain; ``d``/``a`` in mm, angles in degrees."""

    type: Literal["dh"]
    convention: Literal["standard", "modified"] = "standard"
    d: list[Finite] = Field(min_length=1, max_length=16)
    a: list[Finite] = Field(min_length=1, max_length=16)
    alpha_deg: list[Finite] = Field(min_length=1, max_length=16)
    offset_deg: list[Finite] | None = None
    limits: list[Range] | None = None
    """Per joint [lower, upper] in degrees."""
    solver: Literal["numeric", "iiwa"] = "numeric"
    """``iiwa``: the LBR iiwa's analytic inverse (8 configurations); the table must be an iiwa's."""


class Axis(_Strict):
    """The parameters of the MotionPlus Axis Group API's ``axis_group_add_axis``."""

    name: Name
    parent: str = ""
    """Parent axis; empty: the group base."""
    pose: Pose = Pose()
    """Zero-position pose in the parent frame."""
    type: Literal["rotary", "linear"] = "rotary"
    """Rotary about +Z or linear along +Z."""
    v_limit: Annotated[float, Field(gt=0.0)] = 1.0
    """Velocity limit in rad/s or m/s (as ``axis_group_add_axis``)."""
    a_limit: Annotated[float, Field(gt=0.0)] = 1.0
    """Acceleration limit in rad/s^2 or m/s^2 (as ``axis_group_add_axis``)."""
    limits: Range | None = None
    """[lower, upper] in degrees (rotary) or mm (linear); default: unlimited."""
    axis_index: Annotated[int, Field(ge=0, le=5)] | None = None
    link: Name | None = None
    """The link (mesh) this axis moves; default: the axis name."""


class AxisGroup(_Strict):
    """A MotionPlus axis group (Universal Robots); joints in axis-index order."""

    type: Literal["axis_group"]
    pose: Pose = Pose()
    """The group base in the robot base frame."""
    axes: list[Axis] = Field(min_length=1, max_length=6)


class Urdf(_Strict):
    """A URDF or xacro file; joints are its movable joints in file order."""

    type: Literal["urdf"]
    file: str
    """A ``.urdf``, or a ``.xacro`` / ``.urdf.xacro`` expanded with ``args``."""
    packages: dict[str, str] = {}
    """ROS package -> folder, for ``package://name/...`` and ``$(find name)`` (relative
    paths: relative to the cell file); packages not given are searched for above the file."""
    args: dict[str, str] = {}
    """xacro arguments, ``$(arg name)``."""
    xacro_env: list[EnvName] = Field(default=[], max_length=64)
    """Environment variables ``$(env NAME)``/``$(optenv NAME)`` may read; no other is seen."""
    tip: str | None = None
    """The TCP link; default: the last link of the longest chain."""


Kinematics = Annotated[Type12 | DH | AxisGroup | Urdf, Field(discriminator="type")]
KINEMATICS_TYPES = ("type12", "dh", "axis_group", "urdf")


class Robot(_Strict):
    """A robot: where it stands, how it moves, and which nodes drive its joints."""

    name: Name
    source: str
    base: Pose = Pose()
    kinematics: Kinematics
    joints: list[Joint] = Field(default_factory=list, max_length=MAX_JOINTS)
    """One per joint of the kinematics; an RTDE source's robot may leave it out (``actual_q``)."""
    mesh_dir: str | None = None
    """Folder of ``<link>.glb`` meshes (not for URDF, whose visuals are converted)."""
    command_node: str | None = None
    """Node taking ``{"axsPos": [...]}`` moves; default ``motion/grp/<name>/cmd/pos-abs``."""
    demo_targets: list[list[Finite]] | None = None
    """Positions (node units) an embedded mock cycles through; default: drawn within limits."""


class Cell(_Strict):
    """A whole cell file."""

    allow_edits: bool = False
    """Let the page change this file (as ``--allow-edits``; docs/commissioning.md)."""
    source: list[Source] = Field(min_length=1)
    robot: list[Robot] = Field(min_length=1)
