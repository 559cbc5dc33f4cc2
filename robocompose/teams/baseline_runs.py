"""Tables 5.4 and 5.5's baselines as one committed measurement, as the GLSO campaign's runs are.

`measure` is the whole of stage `teams_baselines`' search: NSGA-II per chip x seed x genome x population (and each
setting run alone for the speed column), Table 5.5's coverage baselines and the random-allocation fronts
(experiments.py). It is deterministic and the largest share of a fresh clone's `make run` (~12 min on 2 cores), so
`robocompose teams baselines` runs it once and writes measured/teams/baselines/: its six tables and piece.json (the
key and the runs' wall times). The stage takes the piece while its key matches the current settings, test chips and
code (`piece_key`); otherwise (another profile, an edited optimiser) it measures afresh and says so. Both ways give
the same tables: the piece is `measure`'s own output, checked by `robocompose teams baselines --check`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from robocompose.fanout.executor import Executor
from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.io.atomic import read_json
from robocompose.io.provenance import result_digest, settings_digest
from robocompose.teams.chips import Chip
from robocompose.teams.decompose import Decomposition
from robocompose.teams.evaluator import teams_cache
from robocompose.teams.experiments import coverage_baselines, nsga2_runs, random_fronts
from robocompose.teams.params import TeamsParams

PIECE = Path("measured/teams/baselines")
ENTRY = "robocompose.teams.baseline_runs:measure"
TABLES = {  # file stem (as the stage's output under data/teams/) -> schema
    "nsga2": "teams_nsga2",
    "fronts": "teams_fronts",
    "team_costs": "teams_team_costs",  # every team cost the NSGA-II runs optimised (a record: no stage reads it)
    "coverage": "teams_coverage",
    "random_fronts": "teams_random_fronts",
    "random_points": "teams_random_points",
}
EXPERIMENT_SETTINGS = ("populations", "genomes", "generations", "crossover_probability", "mutation_rate",
                       "table_5_4_chips", "table_5_5_chips", "seeds", "budgets")  # what shapes the baselines


@dataclass
class BaselineRuns:
    """The baselines' tables (keyed as TABLES) and the NSGA-II runs' wall times (not reproducible: kept apart)."""

    tables: dict[str, pd.DataFrame]
    timings: dict  # nsga2_groups, nsga2_alone (experiments.nsga2_runs), measured_seconds


def measure(chips: list[tuple[Chip, Decomposition]], params: TeamsParams,
            executor: Executor | None = None) -> BaselineRuns:
    """Every baseline of Tables 5.4 and 5.5 on the test `chips` (sorted by id), from empty memos."""
    experiments, cache, started = params.experiments, teams_cache(), time.perf_counter()
    runs, fronts, timings = nsga2_runs(chips, params.coverage, experiments, cache, executor)
    coverage = coverage_baselines(chips, params.coverage, experiments, executor)
    random, points = random_fronts(chips, params.coverage, experiments, executor)
    tables = {"nsga2": runs, "fronts": fronts, "team_costs": cache.frame(), "coverage": coverage,
              "random_fronts": random, "random_points": points}
    return BaselineRuns(tables, {**timings, "measured_seconds": round(time.perf_counter() - started, 1)})


def piece_key(params: TeamsParams, chips: list[tuple[Chip, Decomposition]]) -> str:
    """What the committed piece must share with the current run to stand for it: every setting of the chips,
    decomposition and coverage, the experiments' settings that shape a baseline, the threads, the test chips
    themselves (labels and regions: a DroneDeploy directory is read, not named) and the code `measure` runs."""
    settings = {name: dataclasses.asdict(getattr(params, name)) for name in ("chips", "decompose", "coverage")}
    settings["experiments"] = {name: getattr(params.experiments, name) for name in EXPERIMENT_SETTINGS}
    settings["threads"] = params.threads
    used = max(params.experiments.table_5_4_chips, params.experiments.table_5_5_chips)
    chip_bytes = hashlib.sha256()
    for chip, decomposition in chips[:used]:
        chip_bytes.update(chip.chip_id.encode() + chip.classes.tobytes() + decomposition.centres.tobytes() +
                          repr(decomposition.terrain_weight).encode())
    return settings_digest([settings, chip_bytes.hexdigest(), result_digest(ENTRY)])


def write_piece(runs: BaselineRuns, key: str, root: Path = PIECE) -> Path:
    """root/<table>.parquet for each of TABLES and root/piece.json (key, timings)."""
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    write_tables(runs, root)
    atomic_write_json(root / "piece.json", {"key": key, "timings": runs.timings})
    return root


def piece_matches(key: str, root: Path = PIECE) -> bool:
    """Whether root holds a complete piece of `key`."""
    root = Path(root)
    found = root / "piece.json"
    return (found.is_file() and read_json(found).get("key") == key
            and all((root / f"{stem}.parquet").is_file() for stem in TABLES))


def copy_piece(out_dir: Path, root: Path = PIECE) -> dict:
    """Copy the piece's tables (each read against its schema first) to out_dir/<table>.parquet byte for byte; its
    timings."""
    for stem, schema in TABLES.items():
        read_table(root / f"{stem}.parquet", schema)
        shutil.copyfile(root / f"{stem}.parquet", Path(out_dir) / f"{stem}.parquet")
    return read_json(Path(root) / "piece.json")["timings"]


def write_tables(runs: BaselineRuns, out_dir: Path) -> None:
    """out_dir/<table>.parquet for each of TABLES."""
    for stem, schema in TABLES.items():
        write_table(runs.tables[stem], Path(out_dir) / f"{stem}.parquet", schema)
