"""MCAP logs with Foxglove JSON schemas, so rollouts open in Foxglove's 3D panel.

Channels use schema encoding "jsonschema" and message encoding "json". Foxglove recognises a
channel by its schema name (`foxglove.FrameTransforms`, `foxglove.SceneUpdate`); other channels
(`robocompose.Scalars`) are plain JSON and plot in the Plot panel as `/topic.key`.

Typical rollout log: one `/tf` message per step with the transform of every link frame, and one
`/scene` update at t=0 with a frame-locked entity per link (its geometry in the link frame). Foxglove
has no capsule primitive: `capsule_primitives` draws one as a cylinder plus a sphere at each end.

Output is deterministic: the same calls with the same times give the same bytes. The mcap Writer
writes no wall-clock time anywhere; the header records the library string (fixed here), and log and
publish times are the explicit `t` of each call.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.decoder import DecoderFactory
from mcap.reader import make_reader
from mcap.records import Schema
from mcap.writer import CompressionType, Writer

from robocompose.io.atomic import atomic_path
from robocompose.io.errors import ArtifactError

SCALARS = "robocompose.Scalars"
FRAME_TRANSFORMS = "foxglove.FrameTransforms"
SCENE_UPDATE = "foxglove.SceneUpdate"

Vec3 = Sequence[float]
Color = Sequence[float]

# --- Foxglove JSON schemas (abridged to the fields written here; field names as in foxglove-sdk) ---


def _numbers(title: str, keys: str) -> dict[str, Any]:
    return {"title": title, "type": "object", "properties": {k: {"type": "number"} for k in keys}}


def _time_schema(title: str, signed: bool) -> dict[str, Any]:
    sec: dict[str, Any] = {"type": "integer"} if signed else {"type": "integer", "minimum": 0}
    nsec = {"type": "integer", "minimum": 0, "maximum": 999_999_999}
    return {"title": title, "type": "object", "properties": {"sec": sec, "nsec": nsec}}


def _array(items: dict[str, Any]) -> dict[str, Any]:
    return {"type": "array", "items": items}


_TIME = _time_schema("time", signed=False)
_DURATION = _time_schema("duration", signed=True)
_VECTOR3 = _numbers("foxglove.Vector3", "xyz")
_QUATERNION = _numbers("foxglove.Quaternion", "xyzw")
_COLOR = _numbers("foxglove.Color", "rgba")
_POSE = {
    "title": "foxglove.Pose",
    "type": "object",
    "properties": {"position": _VECTOR3, "orientation": _QUATERNION},
}


def _primitive(title: str, **extra: dict[str, Any]) -> dict[str, Any]:
    properties = {"pose": _POSE, "size": _VECTOR3, **extra, "color": _COLOR}
    return {"title": title, "type": "object", "properties": properties}


FRAME_TRANSFORMS_SCHEMA: dict[str, Any] = {
    "title": FRAME_TRANSFORMS,
    "description": "An array of FrameTransform messages",
    "type": "object",
    "properties": {
        "transforms": _array(
            {
                "title": "foxglove.FrameTransform",
                "type": "object",
                "properties": {
                    "timestamp": _TIME,
                    "parent_frame_id": {"type": "string"},
                    "child_frame_id": {"type": "string"},
                    "translation": _VECTOR3,
                    "rotation": _QUATERNION,
                },
            }
        )
    },
}

SCENE_UPDATE_SCHEMA: dict[str, Any] = {
    "title": SCENE_UPDATE,
    "description": "An update to the entities displayed in a 3D scene",
    "type": "object",
    "properties": {
        "deletions": _array(
            {
                "title": "foxglove.SceneEntityDeletion",
                "type": "object",
                "properties": {
                    "timestamp": _TIME,
                    "type": {"title": "foxglove.SceneEntityDeletionType", "enum": [0, 1]},
                    "id": {"type": "string"},
                },
            }
        ),
        "entities": _array(
            {
                "title": "foxglove.SceneEntity",
                "type": "object",
                "properties": {
                    "timestamp": _TIME,
                    "frame_id": {"type": "string"},
                    "id": {"type": "string"},
                    "lifetime": _DURATION,
                    "frame_locked": {"type": "boolean"},
                    "cubes": _array(_primitive("foxglove.CubePrimitive")),
                    "spheres": _array(_primitive("foxglove.SpherePrimitive")),
                    "cylinders": _array(
                        _primitive(
                            "foxglove.CylinderPrimitive",
                            bottom_scale={"type": "number"},
                            top_scale={"type": "number"},
                        )
                    ),
                },
            }
        ),
    },
}

SCALARS_SCHEMA: dict[str, Any] = {
    "title": SCALARS,
    "description": "Named scalar values at one time (a plain JSON channel)",
    "type": "object",
    "properties": {"timestamp": _TIME},
    "additionalProperties": {"type": "number"},
}

# --- message helpers ---


def to_ns(t: float) -> int:
    """Seconds -> integer nanoseconds (MCAP times are unsigned)."""
    if not t >= 0:
        raise ValueError(f"time must be a non-negative number of seconds, got {t!r}")
    return round(t * 1_000_000_000)


def time_msg(t: float) -> dict[str, int]:
    """Foxglove time {sec, nsec} for `t` seconds."""
    sec, nsec = divmod(to_ns(t), 1_000_000_000)
    return {"sec": sec, "nsec": nsec}


def _vec3(v: Vec3) -> dict[str, float]:
    x, y, z = v
    return {"x": float(x), "y": float(y), "z": float(z)}


def _quat(q: Sequence[float]) -> dict[str, float]:
    x, y, z, w = q
    return {"x": float(x), "y": float(y), "z": float(z), "w": float(w)}


def _color(c: Color) -> dict[str, float]:
    r, g, b, a = (*c, 1.0) if len(c) == 3 else c
    return {"r": float(r), "g": float(g), "b": float(b), "a": float(a)}


def pose(position: Vec3 = (0.0, 0.0, 0.0), orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0)) -> dict:
    """Foxglove Pose from a position (x, y, z) and a unit quaternion (x, y, z, w)."""
    return {"position": _vec3(position), "orientation": _quat(orientation)}


def frame_transform(
    parent_frame_id: str,
    child_frame_id: str,
    translation: Vec3 = (0.0, 0.0, 0.0),
    rotation: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
) -> dict:
    """One Foxglove FrameTransform (its timestamp is filled in by `McapWriter.frame_transforms`)."""
    return {
        "parent_frame_id": parent_frame_id,
        "child_frame_id": child_frame_id,
        "translation": _vec3(translation),
        "rotation": _quat(rotation),
    }


def cube_primitive(pose: Mapping[str, Any], size: Vec3, color: Color) -> dict:
    """Foxglove CubePrimitive: a box of edge lengths `size` centred at `pose`; color (r, g, b[, a])."""
    return {"pose": dict(pose), "size": _vec3(size), "color": _color(color)}


def sphere_primitive(pose: Mapping[str, Any], size: Vec3, color: Color) -> dict:
    """Foxglove SpherePrimitive: an ellipsoid with diameters `size` centred at `pose`."""
    return {"pose": dict(pose), "size": _vec3(size), "color": _color(color)}


def cylinder_primitive(
    pose: Mapping[str, Any],
    size: Vec3,
    color: Color,
    bottom_scale: float = 1.0,
    top_scale: float = 1.0,
) -> dict:
    """Foxglove CylinderPrimitive: axis along the pose's z, bounding box `size`, faces scaled 0..1."""
    return {
        "pose": dict(pose),
        "size": _vec3(size),
        "bottom_scale": float(bottom_scale),
        "top_scale": float(top_scale),
        "color": _color(color),
    }


def _rotate(q: Mapping[str, float], v: Vec3) -> tuple[float, float, float]:
    """Rotate vector v by the unit quaternion q: v + 2w(u x v) + 2u x (u x v), u = (x, y, z)."""
    ux, uy, uz, w = q["x"], q["y"], q["z"], q["w"]
    vx, vy, vz = v
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    ccx, ccy, ccz = uy * cz - uz * cy, uz * cx - ux * cz, ux * cy - uy * cx
    return (vx + 2 * (w * cx + ccx), vy + 2 * (w * cy + ccy), vz + 2 * (w * cz + ccz))


def capsule_primitives(pose: Mapping[str, Any], radius: float, length: float, color: Color) -> dict:
    """A capsule as Foxglove primitives: {"cylinders": [body], "spheres": [cap, cap]}.

    The capsule's axis is the pose's z axis and `length` is the length of its cylindrical part
    (pybullet's capsule `height`), so the caps are spheres of `radius` centred at +-length/2 on z.
    Merge the result into a `scene_entity`.
    """
    diameter = 2.0 * radius
    position, orientation = pose["position"], pose["orientation"]
    spheres = []
    for sign in (-1.0, 1.0):
        dx, dy, dz = _rotate(orientation, (0.0, 0.0, sign * length / 2.0))
        centre = (position["x"] + dx, position["y"] + dy, position["z"] + dz)
        cap_pose = {"position": _vec3(centre), "orientation": dict(orientation)}
        spheres.append(sphere_primitive(cap_pose, (diameter, diameter, diameter), color))
    body = cylinder_primitive(pose, (diameter, diameter, length), color)
    return {"cylinders": [body], "spheres": spheres}


def scene_entity(
    entity_id: str,
    frame_id: str,
    *,
    cubes: Iterable[dict] = (),
    spheres: Iterable[dict] = (),
    cylinders: Iterable[dict] = (),
    frame_locked: bool = True,
) -> dict:
    """Foxglove SceneEntity (timestamp filled in by `McapWriter.scene_update`).

    `frame_locked=True` makes the entity follow its frame as later `/tf` messages move it, which is
    what link geometry needs.
    """
    return {
        "id": entity_id,
        "frame_id": frame_id,
        "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": frame_locked,
        "cubes": list(cubes),
        "spheres": list(spheres),
        "cylinders": list(cylinders),
    }


def _stamped(items: Iterable[Mapping[str, Any]], t: float, required: tuple[str, ...], what: str) -> list:
    """Copy each item with `timestamp` defaulting to t, checking the required keys are present."""
    stamped = []
    for i, item in enumerate(items):
        missing = [key for key in required if key not in item]
        if missing:
            raise ValueError(f"{what} {i} lacks {missing} (required: {list(required)})")
        stamped.append({"timestamp": time_msg(t), **item})
    return stamped


# --- writing ---


class McapWriter:
    """Write an MCAP log; the file appears at `path` only when the `with` block ends without error.

    >>> with McapWriter("run.mcap") as log:
    ...     log.scalars("/train", t=0.0, values={"loss": 1.0})
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        self._writer: Writer | None = None
        self._stack = ExitStack()
        self._schema_ids: dict[str, int] = {}
        self._channels: dict[str, tuple[int, str]] = {}  # topic -> (channel id, schema name)
        self._sequence: dict[str, int] = {}

    def __enter__(self) -> McapWriter:
        with ExitStack() as stack:
            tmp = stack.enter_context(atomic_path(self.path))
            stream = stack.enter_context(tmp.open("wb"))
            self._writer = Writer(stream, compression=CompressionType.ZSTD)
            # A fixed library string: the default embeds the mcap package version.
            self._writer.start(profile="", library="robocompose")
            self._stack = stack.pop_all()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: Any) -> None:
        writer, self._writer = self._writer, None
        if exc_type is not None:
            # Hand the exception to atomic_path so it removes the partial file; it then propagates.
            self._stack.__exit__(exc_type, exc, tb)
            return
        with self._stack:
            assert writer is not None
            writer.finish()

    def _write(self, topic: str, schema_name: str, schema: dict[str, Any], t: float, message: dict) -> None:
        if self._writer is None:
            raise RuntimeError(f"{self.path}: McapWriter used outside its `with` block")
        if topic not in self._channels:
            if schema_name not in self._schema_ids:
                data = json.dumps(schema, sort_keys=True).encode()
                self._schema_ids[schema_name] = self._writer.register_schema(schema_name, "jsonschema", data)
            channel_id = self._writer.register_channel(topic, "json", self._schema_ids[schema_name])
            self._channels[topic] = (channel_id, schema_name)
            self._sequence[topic] = 0
        channel_id, channel_schema = self._channels[topic]
        if channel_schema != schema_name:
            raise ValueError(f"topic {topic!r} carries {channel_schema}, cannot log {schema_name} on it")
        try:
            # allow_nan=False: NaN/inf are not JSON and Foxglove would reject the message.
            data = json.dumps(message, separators=(",", ":"), allow_nan=False).encode()
        except ValueError as exc:
            raise ValueError(f"topic {topic!r} at t={t}: {exc}") from exc
        log_time = to_ns(t)
        self._writer.add_message(
            channel_id, log_time=log_time, data=data, publish_time=log_time, sequence=self._sequence[topic]
        )
        self._sequence[topic] += 1

    def scalars(self, topic: str, t: float, values: Mapping[str, float]) -> None:
        """Log named scalars at time t (seconds) on a plain JSON channel."""
        if "timestamp" in values:
            raise ValueError(f"topic {topic!r}: 'timestamp' is reserved, rename that value")
        message = {"timestamp": time_msg(t), **{str(k): float(v) for k, v in values.items()}}
        self._write(topic, SCALARS, SCALARS_SCHEMA, t, message)

    def frame_transforms(self, t: float, transforms: Iterable[Mapping[str, Any]], topic: str = "/tf") -> None:
        """Log foxglove.FrameTransforms (see `frame_transform`); missing timestamps default to t."""
        required = ("parent_frame_id", "child_frame_id", "translation", "rotation")
        message = {"transforms": _stamped(transforms, t, required, "transform")}
        self._write(topic, FRAME_TRANSFORMS, FRAME_TRANSFORMS_SCHEMA, t, message)

    def scene_update(self, t: float, entities: Iterable[Mapping[str, Any]], topic: str = "/scene") -> None:
        """Log a foxglove.SceneUpdate adding/replacing `entities` (see `scene_entity`)."""
        message = {"deletions": [], "entities": _stamped(entities, t, ("id", "frame_id"), "entity")}
        self._write(topic, SCENE_UPDATE, SCENE_UPDATE_SCHEMA, t, message)


# --- reading ---


@dataclass(frozen=True)
class McapMessage:
    """One decoded message of an MCAP log."""

    topic: str
    schema_name: str
    log_time_ns: int
    data: dict[str, Any]


class JsonDecoderFactory(DecoderFactory):
    """Decodes channels with message encoding "json"."""

    def decoder_for(self, message_encoding: str, schema: Schema | None) -> Callable[[bytes], Any] | None:
        return json.loads if message_encoding == "json" else None


def read_mcap(path: str | os.PathLike[str]) -> list[McapMessage]:
    """All messages of the MCAP log at `path`, in log-time order (ties in file order).

    Raises ArtifactError naming the file if it is missing, truncated, corrupted, or holds a channel
    that is not JSON.
    """
    source = Path(path)
    if not source.is_file():
        raise ArtifactError(f"{source}: file not found (expected an MCAP log)")
    try:
        with source.open("rb") as stream:
            reader = make_reader(stream, validate_crcs=True, decoder_factories=[JsonDecoderFactory()])
            return [
                McapMessage(channel.topic, schema.name if schema else "", message.log_time, decoded)
                for schema, channel, message, decoded in reader.iter_decoded_messages()
            ]
    except Exception as exc:  # mcap raises its own errors, struct/zstd/json errors alike on bad input
        raise ArtifactError(f"{source}: not a readable MCAP log ({type(exc).__name__}: {exc})") from exc
