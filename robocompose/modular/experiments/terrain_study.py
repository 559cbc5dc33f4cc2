"""Which terrain distribution makes the best design depend on the terrain? A cheap probe, then the criterion.

Issue 13's criterion, measured on exhaustive tables of >= 8 seeded terrains: >= 3 distinct optimal designs (up
to the left-right mirror) and the design best on average has a mean regret >= 10% of the mean optimum
(`truth.terrain_criterion`). An exhaustive table costs ~1300 rollouts per terrain, so candidate distributions
are first compared on a probe:

- `probe_table`: a fixed set of designs (`PROBE_DESIGNS`: six legs, six wheels, six leg-wheels, the optima and
  best-on-average designs of the committed tables, wheel/leg-wheel mixes and legged mixes) on a few seeded
  terrains under each candidate distribution (a named override of the profile's `terrain` settings), through the
  evaluation cache, so a killed probe resumes;
- `criteria`: the criterion per distribution over whatever terrains a table holds (a probe table restricted to
  the probe designs, or exhaustive tables). On a probe its optima are lower bounds and its regret a proxy: a
  design outside the probe set can only raise an optimum; the best-on-average design may differ too.
- `directory_criterion`: the criterion of the exhaustive tables kept in one directory (one distribution's),
  checked to share one provenance record (settings, fitness rule, physics digest).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.io import read_table
from robocompose.io.errors import InputError
from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.terrain import TerrainConfig, generate_terrain
from robocompose.modular.truth import exhaustive_terrain, read_record, terrain_criterion

# One port string per mirror pair (truth.canonical): legs, wheels and leg-wheels alone; the optima and the
# best-on-average design of the committed tables (measured/modular/exhaustive, H ~ U(0, 0.2)); mixes.
PROBE_DESIGNS = (
    "llllll", "wwwwww", "bbbbbb",
    "wnwwww", "wbwwww", "wnbwnw", "wnwwnw", "bnbbnb", "bbbbwb", "bnbwnw", "bnbwww", "bbbbnb",
    "wbwwbw", "lwwwww", "bbwlww", "bblwnw", "lnllnl", "lbllbl", "blbblb", "wlwwlw",
)


def candidate_settings(settings: EvalSettings, overrides: Mapping[str, Mapping], where: str) -> dict[str, EvalSettings]:
    """The evaluator settings of each candidate: `settings` with its terrain fields replaced by the override."""
    fields = {f.name for f in dataclasses.fields(TerrainConfig)}
    candidates = {}
    for name, override in overrides.items():
        if not isinstance(override, Mapping):
            raise InputError(f"{where}: {name}: expected a mapping of terrain fields, found {override!r}")
        unknown = sorted(set(override) - fields)
        if unknown:
            raise InputError(f"{where}: {name}.{unknown[0]}: unknown terrain field; expected one of {sorted(fields)}")
        terrain = TerrainConfig(**{**settings.terrain.as_dict(), **override})
        candidates[str(name)] = dataclasses.replace(settings, terrain=terrain)
    if not candidates:
        raise InputError(f"{where}: expected at least one candidate distribution")
    return candidates


def probe_table(candidates: Mapping[str, EvalSettings], terrain_seeds: Sequence[int], rule: FitnessRule,
                cache: EvaluationCache | None, executor: Executor | None,
                designs: Sequence[str] = PROBE_DESIGNS,
                on_piece: Callable[[pd.DataFrame], None] | None = None) -> pd.DataFrame:
    """Rows distribution, terrain_seed, terrain_max_height, design, fitness, distance, status, sim_steps, seconds.

    Terrain by terrain, every candidate on each (so a probe stopped early still compares the candidates);
    `on_piece` gets the table so far after each (terrain, candidate), e.g. to write it.
    """
    pieces = []
    for seed in terrain_seeds:
        for name, settings in candidates.items():
            piece = exhaustive_terrain(seed, settings, rule, cache, executor, designs=list(designs))
            piece.insert(0, "distribution", name)
            piece.insert(2, "terrain_max_height", generate_terrain(seed, settings.terrain).max_height)
            pieces.append(piece)
            if on_piece is not None:
                on_piece(pd.concat(pieces, ignore_index=True))
    return pd.concat(pieces, ignore_index=True)


def criteria(table: pd.DataFrame) -> pd.DataFrame:
    """Per distribution (column `distribution`; absent: one): the totals of `truth.terrain_criterion` (`holds`
    among them) and the optimal designs per terrain."""
    groups = table.groupby("distribution", sort=False) if "distribution" in table else [("", table)]
    rows = []
    for name, group in groups:
        per_terrain, totals = terrain_criterion(group[["terrain_seed", "design", "distance"]])
        rows.append({"distribution": name, **totals, "optimum_designs": " ".join(per_terrain.optimum_design)})
    return pd.DataFrame(rows)


def directory_criterion(directory: str | Path) -> tuple[pd.DataFrame, dict]:
    """`truth.terrain_criterion` of the exhaustive tables `blocks-<seed>.parquet` in `directory`, plus the
    provenance they share; a table without its record, or tables measured under different settings, fail."""
    directory = Path(directory)
    paths = sorted(directory.glob("blocks-*.parquet"))
    if not paths:
        raise InputError(f"{directory}: no exhaustive tables (blocks-<seed>.parquet) found")
    records = []
    for path in paths:
        record = path.with_suffix(".json")
        if not record.exists():
            raise InputError(f"{path}: its provenance record {record.name} is missing")
        records.append(read_record(path).provenance)
    if any(r != records[0] for r in records[1:]):
        differing = next(p for p, r in zip(paths, records, strict=True) if r != records[0])
        raise InputError(f"{differing}: measured under other settings, fitness rule or physics than {paths[0].name}")
    table = pd.concat([read_table(p, "modular_exhaustive") for p in paths], ignore_index=True)
    per_terrain, totals = terrain_criterion(table)
    totals["physics_digest"] = records[0]["physics_digest"]
    totals["terrain"] = records[0]["settings"]["terrain"]
    return per_terrain, totals


def rounded(frame: pd.DataFrame, digits: int = 4) -> pd.DataFrame:
    """Floats rounded for a committed CSV (the same results give the same bytes)."""
    floats = frame.select_dtypes(include=[np.floating]).columns
    return frame.assign(**{c: frame[c].round(digits) for c in floats})
