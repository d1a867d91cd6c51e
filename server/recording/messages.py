"""linkview's data as Foxglove's well-known messages, encoded once for every sink.

Frames: ``world`` holds one ``<robot>/base`` frame per robot (where the cell
places it); under it, ``<robot>/<link>`` for every link and ``<robot>/tcp``.
Meshes are ``foxglove.SceneUpdate`` entities locked to the link frames, the
GLB embedded. Joint values are JSON objects named by joint (SI units), which
Foxglove's Plot panel reads as ``/<robot>/joints.position.<joint>``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import orjson
from foxglove import Schema
from foxglove.messages import (
    FrameTransform,
    FrameTransforms,
    Log,
    LogLevel,
    ModelPrimitive,
    Pose,
    Quaternion,
    SceneEntity,
    SceneUpdate,
    Timestamp,
    Vector3,
)

from ..cell import Robot
from ..history.ring import Array

WORLD = "world"
TF_TOPIC = "/tf"
SCENE_TOPIC = "/scene"
LOG_TOPIC = "/log"
TRANSLATION_STEP = 2.0**-20
"""Positions are rounded to about 1 micrometre and quaternions to 2**-22: doubles with
few significant bits compress several times better, far below what a drawing shows."""
ROTATION_STEP = 2.0**-22
# Foxglove turns every glTF from Y-up to Z-up (+90 deg about X); our GLBs are already
# Z-up in the link frame, so each model is turned back by -90 deg about X.
_GLTF_UNDO = Pose(
    position=Vector3(x=0.0, y=0.0, z=0.0),
    orientation=Quaternion(x=-math.sqrt(0.5), y=0.0, z=0.0, w=math.sqrt(0.5)),
)


def joints_topic(robot: str) -> str:
    """Where a robot's joint values go."""
    return f"/{robot}/joints"


def base_frame(robot: str) -> str:
    """The robot's base frame, a child of ``world``."""
    return f"{robot}/base"


def stamp(t: float) -> Timestamp:
    """A Foxglove timestamp of unix time ``t`` (s)."""
    sec = math.floor(t)
    return Timestamp(sec=sec, nsec=min(int(round((t - sec) * 1e9)), 999_999_999))


def nanoseconds(t: float) -> int:
    """Unix time ``t`` (s) as integer nanoseconds (MCAP log times)."""
    return int(round(t * 1e9))


def quantized(poses: Array) -> Array:
    """``(..., 7)`` poses rounded for compression (see TRANSLATION_STEP)."""
    out = np.empty_like(poses)
    out[..., :3] = np.round(poses[..., :3] / TRANSLATION_STEP) * TRANSLATION_STEP
    out[..., 3:] = np.round(poses[..., 3:] / ROTATION_STEP) * ROTATION_STEP
    return out


def _transform(t: Timestamp, parent: str, child: str, pose: list[float]) -> FrameTransform:
    x, y, z, qx, qy, qz, qw = pose
    return FrameTransform(
        timestamp=t,
        parent_frame_id=parent,
        child_frame_id=child,
        translation=Vector3(x=x, y=y, z=z),
        rotation=Quaternion(x=qx, y=qy, z=qz, w=qw),
    )


SCHEMAS = {
    TF_TOPIC: FrameTransforms.get_schema(),
    SCENE_TOPIC: SceneUpdate.get_schema(),
    LOG_TOPIC: Log.get_schema(),
}


@dataclass(frozen=True)
class RobotFrames:
    """The frame names of one robot, made once."""

    robot: Robot

    @cached_property
    def base(self) -> str:
        return base_frame(self.robot.name)

    @cached_property
    def links(self) -> list[str]:
        return [f"{self.robot.name}/{link}" for link in self.robot.link_names]

    @cached_property
    def tcp(self) -> str:
        return f"{self.robot.name}/tcp"

    @cached_property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.robot.joints]


_IDENTITY = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]


def base_transforms(robots: list[Robot], t: float) -> bytes:
    """``world`` -> each robot's base, as the cell places them (and fixed TCP frames)."""
    when = stamp(t)
    transforms = [_transform(when, WORLD, base_frame(r.name), list(r.base)) for r in robots]
    for robot in robots:
        if robot.tcp_is_last_link:  # the TCP is the last link's frame: no need to send it twice
            frames = RobotFrames(robot)
            transforms.append(_transform(when, frames.links[-1], frames.tcp, _IDENTITY))
    return bytes(FrameTransforms(transforms=transforms).encode())


def link_transforms(frames: RobotFrames, t: Array, links: Array, tcp: Array) -> Iterator[bytes]:
    """One encoded ``FrameTransforms`` per row: base -> every link, base -> TCP.

    Where the TCP is the last link, its frame is fixed to it (``base_transforms``).
    """
    links, tcp = quantized(links).tolist(), quantized(tcp).tolist()
    base, names, tcp_name = frames.base, frames.links, frames.tcp
    with_tcp = not frames.robot.tcp_is_last_link
    for k, time in enumerate(t.tolist()):
        when = stamp(time)
        transforms = [
            _transform(when, base, name, pose) for name, pose in zip(names, links[k], strict=True)
        ]
        if with_tcp:
            transforms.append(_transform(when, base, tcp_name, tcp[k]))
        yield bytes(FrameTransforms(transforms=transforms).encode())


JOINT_DECIMALS = 9
"""Joint values are written to 1e-9 rad or m: shorter numbers, far below any encoder."""


def joints_json(frames: RobotFrames, seq: int, t: float, q: list[float]) -> bytes:
    """``{"seq", "t_source", "position": {joint: value}}`` (rad or m)."""
    position = {n: round(v, JOINT_DECIMALS) for n, v in zip(frames.joint_names, q, strict=True)}
    return orjson.dumps({"seq": seq, "t_source": t, "position": position})


def joints_schema(robot: Robot) -> Schema:
    """The JSON schema of a robot's joint messages (lets Foxglove offer the fields)."""
    properties = {j.name: {"type": "number", "description": j.si_unit} for j in robot.joints}
    schema = {
        "type": "object",
        "title": f"{robot.name} joints",
        "properties": {
            "seq": {"type": "integer"},
            "t_source": {"type": "number", "description": "unix s, when the data layer sampled"},
            "position": {"type": "object", "properties": properties},
        },
    }
    return Schema(
        name=f"linkview.Joints.{robot.name}", encoding="jsonschema", data=orjson.dumps(schema)
    )


def scene_update(robots: list[Robot], t: float) -> bytes:
    """Every link mesh as an entity locked to its link frame, the GLB embedded."""
    when = stamp(t)
    entities = []
    for robot in robots:
        frames = RobotFrames(robot)
        for name, mesh in zip(frames.links, robot.meshes, strict=False):
            if mesh is None:
                continue
            model = ModelPrimitive(
                pose=_GLTF_UNDO,
                scale=Vector3(x=1.0, y=1.0, z=1.0),
                media_type="model/gltf-binary",
                data=mesh.read_bytes(),
            )
            entities.append(
                SceneEntity(
                    timestamp=when, frame_id=name, id=name, frame_locked=True, models=[model]
                )
            )
    return bytes(SceneUpdate(entities=entities).encode())


LEVELS = {"info": LogLevel.Info, "warning": LogLevel.Warning, "error": LogLevel.Error}


def log_message(t: float, level: str, name: str, text: str) -> bytes:
    """A ``foxglove.Log`` line: ``name`` is the source (or ``linkview``)."""
    message = Log(timestamp=stamp(t), level=LEVELS[level], message=text, name=name)
    return bytes(message.encode())
