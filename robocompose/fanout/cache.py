"""The evaluation cache shared by every stage and every world: one parquet table of results by key.

A cache holds the rows of one declared table (`robocompose.io.schemas`); its key is a tuple of the
table's key columns and its value is a dict of the remaining columns.

    from robocompose.fanout.cache import EvaluationCache
    cache = EvaluationCache("data/cache/eval_cache.parquet")   # None = memory only; loads the file if present
    key = (design_id, task, settings_hash, seed)               # default table "eval_cache"
    cache.get(key)          # {"reward": 3.9, "status": "ok", "sim_steps": 65536, "seconds": 12.1} or None
    cache.put(key, reward=3.9, status="ok", sim_steps=65536, seconds=12.1)   # every value column, by name
    key in cache; len(cache); cache.merge(other)
    cache.save()            # under a file lock: re-read the file, add this cache's entries, write atomically

Another table: `EvaluationCache(path, table="teams_team_costs", key_columns=("team", "chip_id", "settings_hash",
"seed"))` stores one team's ergodic cost in its region the same way (robocompose/teams/evaluator.py).

Several processes (stages, BO runs, the modular-robot and team worlds) may share one file: `save`
merges under an exclusive lock, so no process loses another's entries (on a key written by both, the
saving process's value wins; evaluations are deterministic so both agree). The file is sorted by key,
so the same entries always give the same bytes. The cache only saves time: stages must give the same
outputs with an empty cache, which is why its file is not a DVC output, and why a corrupt file is moved aside
(`<name>.corrupt`, with a warning) and the cache starts empty.
"""

from __future__ import annotations

import fcntl
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pandas as pd

from robocompose.io import ArtifactError, get_schema, read_table, set_aside, write_table
from robocompose.io.errors import InputError

CacheKey = tuple  # values of the key columns, in order; e.g. (design_id, task, settings_hash, seed)
DEFAULT_CACHE_PATH = Path("data/cache/eval_cache.parquet")
EVAL_KEY_COLUMNS = ("design_id", "task", "settings_hash", "seed")


class EvaluationCache:
    """Rows of table `table` by their `key_columns`, in memory and (optionally) in one parquet file."""

    def __init__(self, path: str | Path | None = None, table: str = "eval_cache",
                 key_columns: tuple[str, ...] = EVAL_KEY_COLUMNS):
        self.path = None if path is None else Path(path)
        self.table = table
        names = get_schema(table).names
        unknown = [c for c in key_columns if c not in names]
        if unknown:
            raise ValueError(f"cache key column {unknown[0]!r} is not a column of table {table!r} ({names})")
        self.key_columns = tuple(key_columns)
        self.value_columns = tuple(c for c in names if c not in key_columns)
        self._rows: dict[CacheKey, dict[str, Any]] = {}
        if self.path is not None and self.path.exists() and not self.path.is_file():  # never set a folder aside
            raise InputError(f"{self.path}: the evaluation cache is not a file (a directory?); expected a parquet "
                             "file or a path not yet taken")
        if self.path is not None and self.path.exists():
            self._rows = self._read()

    def _read(self) -> dict[CacheKey, dict[str, Any]]:
        """The file's entries; a corrupt or truncated file (the cache only saves time) is moved aside, kept
        for inspection, with a warning, and the cache starts empty: never a wrong result, never a stop."""
        try:
            frame = read_table(self.path, self.table)
        except ArtifactError as err:
            set_aside(self.path, str(err).removeprefix(f"{self.path}: "))
            return {}
        rows = {}
        for record in frame.to_dict("records"):
            key = tuple(_plain(record[c]) for c in self.key_columns)
            rows[key] = {c: _plain(record[c]) for c in self.value_columns}
        return rows

    def _check_key(self, key: CacheKey) -> CacheKey:
        key = tuple(key)
        if len(key) != len(self.key_columns):
            raise ValueError(f"cache key {key!r}: expected values for {self.key_columns}")
        return key

    def get(self, key: CacheKey) -> dict[str, Any] | None:
        """The value columns stored for `key` (a copy), or None."""
        row = self._rows.get(self._check_key(key))
        return None if row is None else dict(row)

    def put(self, key: CacheKey, **values: Any) -> None:
        """Store one row; `values` must name exactly the table's value columns."""
        if set(values) != set(self.value_columns):
            raise ValueError(f"cache put {key!r}: expected values {list(self.value_columns)}, got {sorted(values)}")
        self._rows[self._check_key(key)] = {c: _plain(values[c]) for c in self.value_columns}

    def __contains__(self, key: CacheKey) -> bool:
        return self._check_key(key) in self._rows

    def __len__(self) -> int:
        return len(self._rows)

    def merge(self, other: EvaluationCache) -> None:
        """Add every entry of `other` (same table); entries of `other` win."""
        if (other.table, other.key_columns) != (self.table, self.key_columns):
            raise ValueError(f"cannot merge a {other.table!r} cache into a {self.table!r} cache")
        self._rows.update(other._rows)

    def frame(self) -> pd.DataFrame:
        """All entries as a table sorted by key."""
        records = [{**dict(zip(self.key_columns, key, strict=True)), **row} for key, row in sorted(self._rows.items())]
        return pd.DataFrame(records, columns=[*self.key_columns, *self.value_columns])

    def save(self) -> None:
        """Merge with the file on disk (entries of this cache win) and write it; no-op without a path."""
        if self.path is None:
            return
        with _locked(self.path):
            if self.path.exists():
                on_disk = self._read()
                on_disk.update(self._rows)
                self._rows = on_disk
            write_table(self.frame(), self.path, self.table)


def committed_cache(path: str | Path) -> EvaluationCache:
    """The evaluations committed at `path` (an eval_cache table; none if there is no file) as a memory-only cache:
    served like the shared cache's entries, never written back."""
    cache = EvaluationCache()
    if Path(path).is_file():
        for row in read_table(path, "eval_cache").to_dict("records"):
            cache.put(tuple(row.pop(name) for name in EVAL_KEY_COLUMNS), **row)
    return cache


def _plain(value: Any) -> Any:
    """numpy scalars -> Python scalars, NaN -> None (a missing reward is null, not a number)."""
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and value != value:
        return None
    return value


@contextmanager
def _locked(path: Path) -> Iterator[None]:
    """An exclusive advisory lock on `path`.lock for the duration of a read-merge-write."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.with_name(path.name + ".lock"), "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
