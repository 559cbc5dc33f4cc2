"""Training and search checkpoints: the run's key in a small header, checked before anything is deserialised.

    save_checkpoint(path, key, state)                 # torch.save of tensors and plain data, atomically
    save_checkpoint(path, key, state, pickled=True)   # pickle: objects torch cannot store as data
    state = load_checkpoint(path, key)                # None: no checkpoint of this run here, start afresh
    state = load_checkpoint(path, key, named=True)    # a file the user named: InputError instead of None

A checkpoint is one header line, `robocompose-checkpoint <format> <key> <sha256 of the payload>`, and the
payload. `key` is what the caller computes from everything that shapes the run (settings, data, code), so a
checkpoint is resumed only by the run that wrote it. Reading takes the first line only, at most
`HEADER_LIMIT` bytes, and deserialises nothing unless the header parses, its key equals `key` and the
payload's SHA-256 matches; then a torch payload loads with weights_only=True (tensors and plain data: no
code can run) and a pickle payload with pickle.

Why unpickling after the key check is safe to do here: nothing a user or a stray file can hand in reaches
pickle by mistake. A text file, a directory, a foreign pickle (one with a `__reduce__` that runs a command),
a torch file, a checkpoint of another run or of other code: none has this header with this run's key, so
none is read past its first line. The payload must then hash to the header's SHA-256, so a checkpoint cut or
damaged after the header is never unpickled either. What is unpickled is a file this code wrote for this
very run. The key is not a secret, though: someone who deliberately writes a pickle behind a forged header
with the right key can run code, exactly as someone who can edit the repository's code can; the pickle
format is kept only where the state is objects of other libraries (the GLSO methods' optimisers), and only
for files the project writes itself (data/glso/checkpoints) or the user names as their own (`--checkpoint`).

Not a checkpoint of this run (no header, another key): `load_checkpoint` warns one line and returns None
(the run starts afresh and overwrites it), or raises InputError if the user named the file. A damaged one
(its key matches, its payload does not hash to the header) is moved aside (`set_aside`) or, if named, refused.
The bytes depend only on (key, state): a checkpoint that is a DVC output stays reproducible.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import re
import warnings
from pathlib import Path
from typing import Any

from robocompose.io.atomic import atomic_path
from robocompose.io.checked import set_aside
from robocompose.io.errors import ArtifactError, InputError
from robocompose.io.torch_file import load_torch_bytes, torch_bytes

MAGIC = b"robocompose-checkpoint "
HEADER_LIMIT = 256  # bytes of the first line that are read before the key is checked
_HEADER = re.compile(rb"robocompose-checkpoint (torch|pickle) ([0-9a-f]{8,64}) ([0-9a-f]{64})\n")
_KEY = re.compile(r"[0-9a-f]{8,64}")


def save_checkpoint(path: str | os.PathLike[str], key: str, state: Any, pickled: bool = False) -> Path:
    """Write `state` behind the header of `key`, atomically: torch.save (tensors and plain data) or, with
    `pickled`, pickle (any objects; see the module docstring for when). Returns the path."""
    if not _KEY.fullmatch(key):
        raise ValueError(f"checkpoint key {key!r}: expected 8 to 64 lowercase hex digits")
    kind = "pickle" if pickled else "torch"
    payload = pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL) if pickled else torch_bytes(state)
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
    if header.group(1) == b"pickle":
        return pickle.loads(payload)  # a file written for this run by this code (the header says so; see above)
    return load_torch_bytes(payload, source)


def _not_ours(source: Path, reason: str, named: bool) -> None:
    if named:
        raise InputError(f"{source}: {reason}; name a checkpoint of this run or a new file")
    warnings.warn(f"{source}: {reason}: starting afresh", stacklevel=3)
    return None
