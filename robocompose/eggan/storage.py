"""Torch files of EG-GAN and its problems (generators, Q-networks, training checkpoints) behind a checksum header.

A flipped byte inside a tensor is read by torch.load without complaint; `robocompose.io.write_checked` puts the
payload's SHA-256 in front of it, so a truncated or corrupted file is an ArtifactError naming it.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import torch

from robocompose.io.checked import read_checked, write_checked
from robocompose.io.errors import InputError


def save_torch(obj: object, path: str | os.PathLike[str]) -> Path:
    """torch.save `obj` to `path` behind the checksum header, atomically.

    Serialised through memory, so the bytes do not depend on the file name (torch names the archive's
    folder after the file it writes, which for an atomic write is a random temporary name)."""
    buffer = io.BytesIO()
    torch.save(obj, buffer)
    return write_checked(path, buffer.getvalue())


def load_torch(path: str | os.PathLike[str], weights_only: bool = True) -> object:
    """What `save_torch` wrote, on the CPU; ArtifactError naming the file if it is truncated or corrupted.

    `weights_only=False` only for the project's own checkpoints, whose checksum has just been verified."""
    return torch.load(io.BytesIO(read_checked(path)), map_location="cpu", weights_only=weights_only)


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
