"""Atomic file writes: an artifact is either complete or absent, never half-written; checked JSON reads."""

from __future__ import annotations

import json
import os
import re
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from robocompose.io.errors import ArtifactError


@contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a hidden temporary path next to `path`; rename it onto `path` on success.

    The temporary file lives in the same directory (so `os.replace` is an atomic rename on one
    filesystem) and keeps the suffix (so writers that dispatch on it behave). The caller creates
    the file. On an exception the temporary file is removed, `path` is left untouched and the
    exception propagates. A process killed mid-write (SIGKILL runs no cleanup) leaves its
    temporary file behind: the next write of the same `path` removes those of writers no longer
    running, so a killed-and-resumed stage leaves the same files as an uninterrupted one. This
    protects against crashes of the process, not against power loss (no fsync).
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(target)
    # Not created here (unlike mkstemp) so the file gets the usual umask permissions, not 0600.
    tmp = target.with_name(f".{target.stem}.{os.getpid()}.{secrets.token_hex(4)}.tmp{target.suffix}")
    try:
        yield tmp
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def remove_stale_temporaries(path: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporary files `atomic_path` left next to `path` for writers that are no longer running
    (their pid is in the name); return them. A live writer's file is kept."""
    target = Path(path)
    pattern = re.compile(rf"\.{re.escape(target.stem)}\.(\d+)\.[0-9a-f]{{8}}\.tmp{re.escape(target.suffix)}")
    removed = []
    for candidate in target.parent.glob(f".{target.stem}.*.tmp{target.suffix}"):
        match = pattern.fullmatch(candidate.name)
        if match is not None and not _running(int(match.group(1))):
            candidate.unlink(missing_ok=True)
            removed.append(candidate)
    return removed


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: running
        return True
    return True


def atomic_write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write `text` (UTF-8) to `path` atomically and return the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def atomic_write_json(path: str | os.PathLike[str], obj: Any) -> Path:
    """Write `obj` as JSON (sorted keys, indent 2, trailing newline) atomically; return the path."""
    return atomic_write_text(path, json.dumps(obj, sort_keys=True, indent=2) + "\n")


def read_json(path: str | os.PathLike[str]) -> Any:
    """The JSON document at `path` (as `atomic_write_json` writes it); ArtifactError naming the file if it is
    missing or not valid JSON."""
    source = Path(path)
    if not source.is_file():
        raise ArtifactError(f"{source}: file not found (expected a JSON file)")
    try:
        return json.loads(source.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ArtifactError(f"{source}: not valid JSON ({err})") from None
