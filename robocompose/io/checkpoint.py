"""Training and search checkpoints: plain data behind a header with the run's key, checked before the payload is read.

    save_checkpoint(path, key, state)                # torch.save of tensors and plain data, atomically
    save_checkpoint(path, key, state, kind="json")   # JSON text of plain data (a search run's step rows)
    state = load_checkpoint(path, key)               # None: no checkpoint of this run here, start afresh
    state = load_checkpoint(path, key, named=True)   # a file the user named: InputError instead of None

A checkpoint is one header line, `robocompose-checkpoint <torch|json> <key> <sha256 of the payload>`, and the
payload. `key` is what the caller computes from everything that shapes the run (settings, data, code), so a
checkpoint is resumed only by the run that wrote it. Reading takes the first line only, at most
`HEADER_LIMIT` bytes, and reads the payload only if the header parses, its key equals `key` and the payload's
SHA-256 matches (a checkpoint cut or damaged after the header is never loaded).

The key tells a checkpoint of this run from a stale or stray file; it does not tell who wrote the file. Anyone
can compute it (it is a hash of settings, code and model that are all at hand, and the refusal of another
run's checkpoint prints it), so a forged file can carry the right key and a matching hash. What keeps such a
file harmless is the payload's format: plain data only, loaded by loaders that cannot run code. A torch
payload loads with weights_only=True (tensors, numbers, strings, lists, dicts; torch refuses any other
object), a JSON payload with `json.loads`. Nothing is unpickled: state that is objects of other libraries
(the GLSO methods' optimisers, search trees, networks) is not saved; the run saves its plain record and
rebuilds the objects from it (`robocompose.glso.runs` replays its steps). A forged checkpoint can at most hand
a run wrong data, which the run checks as far as it can (a GLSO replay must propose the recorded designs).
Checkpoints of the former pickle format are not read.

Not a checkpoint of this run (no header, another key, a format this code does not read): `load_checkpoint`
warns one line and returns None (the run starts afresh and overwrites it), or raises InputError if the user
named the file. A damaged one (its key matches, its payload does not hash to the header) is moved aside
(`set_aside`) or, if named, refused. A payload that hashes right but does not load is an ArtifactError. The
bytes depend only on (key, state): a checkpoint that is a DVC output stays reproducible.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import warnings
from pathlib import Path
from typing import Any, Literal

from robocompose.io.atomic import atomic_path
from robocompose.io.checked import set_aside
from robocompose.io.errors import ArtifactError, InputError
from robocompose.io.torch_file import load_torch_bytes, torch_bytes

MAGIC = b"robocompose-checkpoint "
HEADER_LIMIT = 256  # bytes of the first line that are read before the key is checked
# Any format word parses, so that a checkpoint of a format this code does not read (the former "pickle") is
# refused by name rather than as "not a checkpoint".
_HEADER = re.compile(rb"robocompose-checkpoint ([a-z]{1,16}) ([0-9a-f]{8,64}) ([0-9a-f]{64})\n")
_KEY = re.compile(r"[0-9a-f]{8,64}")
FORMATS = ("torch", "json")


def save_checkpoint(path: str | os.PathLike[str], key: str, state: Any,
                    kind: Literal["torch", "json"] = "torch") -> Path:
    """Write `state` behind the header of `key`, atomically, as torch.save (tensors and plain data) or JSON
    (dicts, lists, strings, numbers, booleans, None; NaN too). Returns the path."""
    if not _KEY.fullmatch(key):
        raise ValueError(f"checkpoint key {key!r}: expected 8 to 64 lowercase hex digits")
    if kind not in FORMATS:
        raise ValueError(f"checkpoint format {kind!r}: expected one of {FORMATS}")
    payload = json.dumps(state, separators=(",", ":")).encode() if kind == "json" else torch_bytes(state)
    with atomic_path(path) as tmp, open(tmp, "wb") as handle:
        handle.write(MAGIC + f"{kind} {key} {hashlib.sha256(payload).hexdigest()}\n".encode())
        handle.write(payload)
    return Path(path)


def load_checkpoint(path: str | os.PathLike[str] | None, key: str, named: bool = False) -> Any | None:
    """The state `save_checkpoint` wrote to `path` for `key`, or None if there is none to resume (see the
    module docstring); `named`: the user gave this path, so a file that is not this run's is an InputError."""
    if path is None:
        return None
    source = Path(path)
    if not source.exists():
        return None
    if not source.is_file():
        raise InputError(f"{source}: is a directory, not a checkpoint file (expected a file this run writes)")
    with open(source, "rb") as handle:
        first = handle.readline(HEADER_LIMIT)
        header = _HEADER.fullmatch(first)
        if header is None:
            return _not_ours(source, "not a robocompose checkpoint (no checkpoint header)", named)
        kind = header.group(1).decode()
        if kind not in FORMATS:
            return _not_ours(source, f"a checkpoint in the {kind} format, which is not read (checkpoints hold plain "
                                     f"data only: {' or '.join(FORMATS)})", named)
        if header.group(2).decode() != key:
            return _not_ours(source, f"a checkpoint of another run or other code (key {header.group(2).decode()}, "
                                     f"this run's key {key})", named)
        payload = handle.read()
    if hashlib.sha256(payload).hexdigest() != header.group(3).decode():
        reason = f"checksum mismatch, the checkpoint is truncated or corrupted ({len(payload)} bytes after the header)"
        if named:
            raise ArtifactError(f"{source}: {reason}")
        set_aside(source, reason)
        return None
    if kind == "json":
        return _load_json(payload, source)
    return load_torch_bytes(payload, source)


def _load_json(payload: bytes, source: Path) -> Any:
    try:
        return json.loads(payload)
    except (ValueError, RecursionError) as err:  # not UTF-8 or not JSON (ValueError both), or nested too deep
        raise ArtifactError(f"{source}: the checkpoint's JSON payload does not parse ({type(err).__name__})") from None


def _not_ours(source: Path, reason: str, named: bool) -> None:
    if named:
        raise InputError(f"{source}: {reason}; name a checkpoint of this run or a new file")
    warnings.warn(f"{source}: {reason}: starting afresh", stacklevel=3)
    return None
