"""Artifacts: atomic writes, checksummed binary files, schema-checked parquet tables, MCAP logs (Foxglove schemas),
input errors.

Names load on first use (PEP 562), so `robocompose.io.errors` and `robocompose.arguments` (needed while
the command line is parsed) do not pull in pandas, pyarrow and mcap.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_EXPORTS = {
    "robocompose.io.atomic": ("atomic_path", "atomic_write_json", "atomic_write_text", "read_json"),
    "robocompose.io.checked": ("read_checked", "set_aside", "write_checked"),
    "robocompose.io.errors": ("ArtifactError", "InputError"),
    "robocompose.io.mcap_log": (
        "FRAME_TRANSFORMS", "SCALARS", "SCENE_UPDATE", "JsonDecoderFactory", "McapMessage", "McapWriter",
        "capsule_primitives", "cube_primitive", "cylinder_primitive", "frame_transform", "pose", "read_mcap",
        "scene_entity", "sphere_primitive", "time_msg", "to_ns",
    ),
    "robocompose.io.schemas": ("LIST_LENGTHS", "SCHEMAS", "get_schema"),
    "robocompose.io.tables": ("read_table", "write_table"),
}
_MODULE_OF = {name: module for module, names in _EXPORTS.items() for name in names}
__all__ = sorted(_MODULE_OF)


def __getattr__(name: str) -> Any:
    if name not in _MODULE_OF:
        raise AttributeError(f"module 'robocompose.io' has no attribute {name!r}")
    return getattr(importlib.import_module(_MODULE_OF[name]), name)


if TYPE_CHECKING:  # for type checkers and editors: the same names, imported eagerly
    from robocompose.io.atomic import atomic_path, atomic_write_json, atomic_write_text, read_json  # noqa: F401
    from robocompose.io.checked import read_checked, set_aside, write_checked  # noqa: F401
    from robocompose.io.errors import ArtifactError, InputError  # noqa: F401
    from robocompose.io.mcap_log import (  # noqa: F401
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
    from robocompose.io.schemas import LIST_LENGTHS, SCHEMAS, get_schema  # noqa: F401
    from robocompose.io.tables import read_table, write_table  # noqa: F401
