"""Re-keying the committed teams pieces after a code change that leaves their results as they were.

A generator piece (measured/teams/generators/seed-K/) and a chip-count piece (measured/teams/chip_count/) carry
the key of the settings and the code that made them (`generators.piece_key`, `chip_count.piece_key`). A change of
any code their result can reach (e.g. EG-GAN's trainer gaining an option the teams world does not use) makes every
piece stale, and stage `teams_heldout` drops it: hours of training lost to an edit that moved no number.

`verify` re-makes one stale piece of each kind under today's code (the cheapest: fewest training chips) and
compares every result it holds (tables cell for cell, every field of its record but the wall time and the key).
Only if all agree are the stale pieces of that kind that had the *same* old key (so the same settings and code as
the one re-made) re-keyed; each records the key it had and the piece that proved it (`rekeyed`). A piece of other
settings keeps its stale key: re-making one piece proves the code, not a settings change.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from robocompose.io import atomic_write_json, read_table
from robocompose.io.atomic import read_json
from robocompose.teams import chip_count, generators
from robocompose.teams.chips import Chip
from robocompose.teams.decompose import Decomposition
from robocompose.teams.params import TeamsParams

Split = list[tuple[Chip, Decomposition]]
UNCOMPARED = ("key", "training_seconds", "rekeyed")  # a record's fields that are not results


def differences(stored: dict, remade: dict) -> list[str]:
    """The result fields of a piece's record whose stored and re-made values differ (or that one side lacks)."""
    names = (set(stored) | set(remade)) - set(UNCOMPARED)
    return sorted(name for name in names if stored.get(name) != remade.get(name))


def table_differences(stored: Path, remade: Path) -> list[str]:
    """The tables of a generator piece that differ from the re-made piece's in any cell, dtype or order."""
    def read(directory: Path, name: str) -> pd.DataFrame:
        return read_table(directory / f"{name}.parquet", f"teams_{name}")

    return [f"{name}.parquet" for name in ("eggan_queries", "eggan_fronts")
            if not read(stored, name).equals(read(remade, name))]


def _rekey(paths: list[Path], key: str, proof: str, record_path: Callable[[Path], Path]) -> list[str]:
    for path in paths:
        record = read_json(record_path(path))
        atomic_write_json(record_path(path), {**record, "key": key,
                                              "rekeyed": {"from": record["key"], "reproduced_by": proof}})
    return [str(p) for p in paths]


def verify_generators(params: TeamsParams, train: Split, test: Split, rekey: bool,
                      root: Path = generators.PIECES) -> dict:
    """Re-make the first stale generator piece; if it agrees, re-key (with `rekey`) the stale pieces of its key."""
    key = generators.piece_key(params)
    stale = [d for d in sorted(Path(root).glob("seed-*")) if read_json(d / "piece.json").get("key") != key]
    if not stale:
        return {"kind": "generators", "stale": [], "rekeyed": []}
    probe = stale[0]
    stored = read_json(probe / "piece.json")
    with tempfile.TemporaryDirectory() as scratch:
        generated = generators.train_and_query(params, int(stored["seed"]), train, test,
                                               Path(scratch) / "checkpoint.pt")
        remade = generators.write_piece(generated, params, int(stored["seed"]), Path(scratch))
        differ = differences(stored, read_json(remade / "piece.json")) + table_differences(probe, remade)
    same_origin = [d for d in stale if read_json(d / "piece.json")["key"] == stored["key"]]
    done = _rekey(same_origin, key, probe.name, lambda d: d / "piece.json") if rekey and not differ else []
    return {"kind": "generators", "stale": [str(d) for d in stale], "reproduced": str(probe),
            "differences": differ, "rekeyed": done}


def verify_chip_count(params: TeamsParams, train: Split, rekey: bool, root: Path = chip_count.PIECES) -> dict:
    """Re-measure the stale chip-count piece of fewest chips; if it agrees, re-key (with `rekey`) the stale pieces
    of its key."""
    key = chip_count.piece_key(params)
    stale = [p for p in sorted(Path(root).glob("train-*-seed-*.json")) if read_json(p).get("key") != key]
    if not stale:
        return {"kind": "chip_count", "stale": [], "rekeyed": []}
    probe = min(stale, key=lambda p: (read_json(p)["train_chips"], p.name))
    stored = read_json(probe)
    with tempfile.TemporaryDirectory() as scratch:
        remade = chip_count.measure(params, train, int(stored["train_chips"]), int(stored["seed"]),
                                    Path(scratch) / "checkpoint.pt")
    differ = differences(stored, remade)
    same_origin = [p for p in stale if read_json(p)["key"] == stored["key"]]
    done = _rekey(same_origin, key, probe.name, lambda p: p) if rekey and not differ else []
    return {"kind": "chip_count", "stale": [str(p) for p in stale], "reproduced": str(probe),
            "differences": differ, "rekeyed": done}
