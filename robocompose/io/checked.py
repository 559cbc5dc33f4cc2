"""Binary artifacts with a checksum: a corrupted or truncated file is detected, never read as data.

Parquet carries its own page checksums (`robocompose.io.tables`); other binary artifacts (torch models and
checkpoints) do not: torch.load reads a file with a flipped byte inside a tensor without complaint. Such
a payload is written as one header line (a magic word and the SHA-256 of the payload) followed by the
payload, atomically:

    write_checked("models/m.pt", payload)     # bytes, e.g. torch.save into a BytesIO
    payload = read_checked("models/m.pt")     # ArtifactError naming the file if it does not check out
    set_aside(path, reason)                   # a corrupt file that only saves time: keep it, warn, go on
"""

from __future__ import annotations

import hashlib
import os
import re
import warnings
from pathlib import Path

from robocompose.io.atomic import atomic_path
from robocompose.io.errors import ArtifactError

MAGIC = b"robocompose-sha256 "
_HEADER = re.compile(rb"robocompose-sha256 ([0-9a-f]{64})\n")


def write_checked(path: str | os.PathLike[str], payload: bytes) -> Path:
    """Write `payload` to `path` behind a SHA-256 header line, atomically; return the path."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as handle:
            handle.write(MAGIC + hashlib.sha256(payload).hexdigest().encode() + b"\n")
            handle.write(payload)
    return Path(path)


def read_checked(path: str | os.PathLike[str]) -> bytes:
    """The payload of a file written by `write_checked`.

    Raises FileNotFoundError if it is missing and ArtifactError naming the file if it has no checksum
    header (an older or foreign file) or its payload does not match the checksum (truncated, corrupted).
    """
    source = Path(path)
    if not source.is_file():
        raise FileNotFoundError(f"{source}: no such file")
    data = source.read_bytes()
    header = _HEADER.match(data)
    if header is None:
        raise ArtifactError(f"{source}: no checksum header (expected a file written by robocompose.io.write_checked)")
    payload = data[header.end():]
    found = hashlib.sha256(payload).hexdigest()
    if found != header.group(1).decode():
        raise ArtifactError(f"{source}: checksum mismatch, the file is truncated or corrupted (header sha256 "
                            f"{header.group(1).decode()[:12]}..., content {found[:12]}..., {len(payload)} bytes)")
    return payload


def set_aside(path: str | os.PathLike[str], reason: str) -> Path:
    """Rename a corrupt file that only saves time (a cache, a checkpoint) to `<name>.corrupt[-N]` next to it,
    keeping it for inspection, and warn; the caller then starts afresh. Returns the new path."""
    source = Path(path)
    target, n = source.with_name(source.name + ".corrupt"), 1
    while target.exists():
        target, n = source.with_name(f"{source.name}.corrupt-{n}"), n + 1
    os.replace(source, target)
    warnings.warn(f"{source}: {reason}; moved aside to {target.name}, starting afresh", stacklevel=2)
    return target
