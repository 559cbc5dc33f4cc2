"""Trained networks of EG-GAN and its problems (generators, Q-networks): their state and info in one torch file
behind the checksum header of `robocompose.io.save_torch`, the info as JSON beside it."""

from __future__ import annotations

import os
from pathlib import Path

from robocompose.io.errors import InputError
from robocompose.io.torch_file import load_torch, save_torch


def save_model(info: dict, state: dict, path: str | os.PathLike[str]) -> Path:
    """A trained network's file: {"info", "state"} behind the checksum header, and `info` as JSON beside it.

    `info` goes in as JSON text: pickle's bytes depend on which equal strings are one object (a run resumed from
    a checkpoint has other string objects than a straight one), JSON's do not."""
    import json

    from robocompose.io import atomic_write_json

    save_torch({"info": json.dumps(info, sort_keys=True), "state": state}, path)
    atomic_write_json(Path(path).with_suffix(".json"), info)
    return Path(path)


def load_model(path: str | os.PathLike[str], kind: str) -> tuple[dict, dict]:
    """(info, state) of a file `save_model` wrote; InputError naming the file if it is missing or of another kind
    (`kind` names what was expected, e.g. "an EG-GAN generator"), ArtifactError if it is cut or corrupted."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file (expected {kind} file)")
    import json

    saved = load_torch(path)  # the checksum first: a cut file never reaches torch
    try:
        return json.loads(saved["info"]), saved["state"]
    except (KeyError, TypeError, json.JSONDecodeError) as err:  # a checked file of another kind
        raise InputError(f"{path}: not {kind} file (no {err})") from None
