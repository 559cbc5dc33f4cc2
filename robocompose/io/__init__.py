"""Artifacts: atomic writes, checksummed binary files, schema-checked parquet tables, MCAP logs (Foxglove)."""

from robocompose.io.atomic import atomic_path, atomic_write_json, atomic_write_text
from robocompose.io.checked import read_checked, set_aside, write_checked
from robocompose.io.errors import ArtifactError
from robocompose.io.mcap_log import (
    FRAME_TRANSFORMS,
    SCALARS,
    SCENE_UPDATE,
    JsonDecoderFactory,
    McapMessage,
    McapWriter,
    capsule_primitives,
    cube_primitive,
    cylinder_primitive,
    frame_transform,
    pose,
    read_mcap,
    scene_entity,
    sphere_primitive,
    time_msg,
    to_ns,
)
from robocompose.io.schemas import LIST_LENGTHS, SCHEMAS, get_schema
from robocompose.io.tables import read_table, write_table

__all__ = [
    "FRAME_TRANSFORMS",
    "LIST_LENGTHS",
    "SCALARS",
    "SCENE_UPDATE",
    "SCHEMAS",
    "ArtifactError",
    "JsonDecoderFactory",
    "McapMessage",
    "McapWriter",
    "atomic_path",
    "atomic_write_json",
    "atomic_write_text",
    "capsule_primitives",
    "cube_primitive",
    "cylinder_primitive",
    "frame_transform",
    "get_schema",
    "pose",
    "read_checked",
    "read_mcap",
    "read_table",
    "scene_entity",
    "set_aside",
    "sphere_primitive",
    "time_msg",
    "to_ns",
    "write_checked",
    "write_table",
]
