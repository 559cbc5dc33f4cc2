"""Exhaustive ground truth of the modular world: every design on a terrain, and the terrain criterion.

- `exhaustive_terrain`: all 4096 port strings on one terrain under the fitness rule (the 1296 designs the original
  accepts simulated, the rest scored by the rule), through the shared cache, so a long table resumes.
- Committed one-offs: a table is also kept under `measured/modular/exhaustive/blocks-<seed>.parquet` with a JSON
  record of the settings, fitness rule and physics code it was measured with. The `modular_exhaustive` stage
  uses such a table when all three match the current ones, and simulates otherwise (a changed profile, e.g.
  `paper`, regenerates its own).
- `terrain_criterion`: does the best design depend on the terrain? Per terrain its optimum, the single design
  best on average over the terrains, and that design's regret; the count of distinct optima up to the
  left-right mirror (thesis Fig. 5.1: near-flat ground favours wheels, rough ground other modules).
- `pool_metrics`: the training pool's distinct optima, best-on-average design and regret per split.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import pandas as pd

from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.io.atomic import read_json
from robocompose.io.errors import ArtifactError, InputError
from robocompose.io.provenance import result_digest
from robocompose.modular import evaluate
from robocompose.modular.evaluate import EvalSettings, FitnessRule, evaluate_designs
from robocompose.modular.robot import all_designs, mirror
from robocompose.modular.terrain import TerrainConfig, generate_terrain

COMMITTED_DIR = Path("measured/modular/exhaustive")
# Issue 13's terrain criterion: on >= 8 terrains, >= 3 distinct optima (up to mirror) and the best-on-average
# design's mean regret >= 10% of the mean optimum.
CRITERION = {"terrains": 8, "distinct_optima": 3, "regret_ratio": 0.10}


def exhaustive_terrain(terrain_seed: int, settings: EvalSettings, rule: FitnessRule,
                       cache: EvaluationCache | None, executor: Executor | None, save_every: int = 32,
                       designs: list[str] | None = None) -> pd.DataFrame:
    """Rows terrain_seed, design, fitness, distance, status, sim_steps, seconds of every design, sorted by design.

    `designs` restricts the table to a subset (tests); None is all 4096.
    """
    designs = sorted(all_designs() if designs is None else designs)
    results = evaluate_designs(designs, terrain_seed, settings, rule, cache, executor, save_every)
    return pd.DataFrame({"terrain_seed": int(terrain_seed), "design": designs,
                         "fitness": [rule.fitness(r) for r in results], "distance": [r.distance for r in results],
                         "status": [r.status for r in results], "sim_steps": [r.sim_steps for r in results],
                         "seconds": [r.seconds for r in results]})


def physics_digest() -> str:
    """16 hex digits of the code and constants a rollout reaches (`result_digest` of the evaluator's entry points):
    a change of layout, comments, docstrings, imports, error messages or a move of code keeps the digest."""
    return result_digest(*evaluate.RESULT_CODE)


def provenance(settings: EvalSettings, rule: FitnessRule) -> dict:
    """What a table's numbers depend on: the settings and rule (as plain JSON) and the physics code's digest."""
    return json.loads(json.dumps({"settings": asdict(settings), "fitness": asdict(rule),
                                  "physics_digest": physics_digest()}, sort_keys=True))


def committed_path(terrain_seed: int, directory: Path = COMMITTED_DIR) -> Path:
    return Path(directory) / f"blocks-{int(terrain_seed)}.parquet"


def write_committed(table: pd.DataFrame, settings: EvalSettings, rule: FitnessRule, seconds: float,
                    directory: Path = COMMITTED_DIR, extra: dict | None = None) -> Path:
    """Keep one terrain's table and its provenance record (`.json` beside it, with the fields of `extra`: a partial
    table's design set) under `directory`."""
    seeds = table.terrain_seed.unique()
    if len(seeds) != 1:
        raise ValueError(f"a committed table holds one terrain, found seeds {sorted(seeds)}")
    path = committed_path(int(seeds[0]), directory)
    write_table(table, path, "modular_exhaustive")
    atomic_write_json(path.with_suffix(".json"), {
        **provenance(settings, rule), **(extra or {}), "terrain_seed": int(seeds[0]), "designs": len(table),
        "simulated": int((table.sim_steps > 0).sum()), "wall_seconds": round(seconds, 1)})
    return path


PROVENANCE_KEYS = ("settings", "fitness", "physics_digest")  # what a committed table's numbers depend on


@dataclass(frozen=True)
class CommittedRecord:
    """The provenance record beside a committed table, checked (`read_record`): the JSON document as stored and
    the settings and fitness rule it names, built as the params loader builds them."""

    document: dict
    settings: EvalSettings
    rule: FitnessRule

    @property
    def provenance(self) -> dict:
        return {k: self.document[k] for k in PROVENANCE_KEYS}


def read_record(table: Path) -> CommittedRecord:
    """The provenance record (`.json` beside `table`) every reader of a committed table goes through: a JSON
    object whose `settings` and `fitness` load as the params' `modular.eval` and `modular.fitness` do (no unknown
    field, the right types and ranges) and whose `physics_digest` is a string; ArtifactError naming the record,
    the field and what was expected otherwise."""
    from robocompose.params import build_config

    path = Path(table).with_suffix(".json")
    document = read_json(path)
    if not isinstance(document, dict):
        raise ArtifactError(f"{path}: expected a JSON object with fields {list(PROVENANCE_KEYS)} (a committed "
                            f"table's provenance record), found a {type(document).__name__}")
    missing = [k for k in PROVENANCE_KEYS if k not in document]
    if missing:
        raise ArtifactError(f"{path}: {missing[0]}: missing field (a committed table's provenance record holds "
                            f"{list(PROVENANCE_KEYS)})")
    settings = build_config(EvalSettings, document["settings"], f"{path}: settings")
    rule = build_config(FitnessRule, document["fitness"], f"{path}: fitness")
    digest = document["physics_digest"]
    if not isinstance(digest, str):
        raise ArtifactError(f"{path}: physics_digest: expected a string of hex digits, found {digest!r}")
    return CommittedRecord(document, settings, rule)


def read_committed(terrain_seed: int, settings: EvalSettings, rule: FitnessRule,
                   directory: Path = COMMITTED_DIR) -> pd.DataFrame | None:
    """The committed table of `terrain_seed` if it was measured with these settings, rule and physics; else None."""
    path = committed_path(terrain_seed, directory)
    record = path.with_suffix(".json")
    if not (path.exists() and record.exists()):
        return None
    if read_record(path).provenance != provenance(settings, rule):
        return None
    return read_table(path, "modular_exhaustive")


def truth_tables(terrain_seeds: list[int], settings: EvalSettings, rule: FitnessRule,
                 cache: EvaluationCache | None, executor: Executor | None,
                 directory: Path = COMMITTED_DIR) -> tuple[pd.DataFrame, dict[int, str]]:
    """The exhaustive table of every terrain (committed where it matches, else simulated) and each one's source."""
    frames, sources = [], {}
    committed = {seed: read_committed(seed, settings, rule, directory) for seed in terrain_seeds}  # checked first
    for seed in terrain_seeds:
        table = committed[seed]
        sources[int(seed)] = "committed" if table is not None else "simulated"
        if table is None:
            table = exhaustive_terrain(seed, settings, rule, cache, executor)
        frames.append(table)
    return pd.concat(frames, ignore_index=True).sort_values(["terrain_seed", "design"], ignore_index=True), sources


def measure_committed(terrain_seed: int, settings: EvalSettings, rule: FitnessRule, cache: EvaluationCache,
                      executor: Executor | None, directory: Path = COMMITTED_DIR, designs: list[str] | None = None,
                      extra: dict | None = None) -> Path:
    """Simulate one terrain's table (resuming from the cache; `designs`: a partial table of those only) and commit
    it under `directory`, `extra` added to its record."""
    started = time.perf_counter()
    table = exhaustive_terrain(terrain_seed, settings, rule, cache, executor, designs=designs)
    cache.save()
    return write_committed(table, settings, rule, time.perf_counter() - started, directory, extra)


def verify_committed(path: Path, sample: int, seed: int, executor: Executor | None = None,
                     rekey: bool = False) -> dict:
    """Re-simulate `sample` random simulated designs of one committed table under its own settings and rule, and
    compare distance, status and sim steps exactly. With `rekey` and every row equal, the record's physics digest
    becomes the current one: the proof that a change of code (or of the digest's scheme) left the numbers as
    they were, instead of re-keying blindly. Returns the comparison (and whether the record was re-keyed)."""
    if sample < 1:
        raise InputError(f"sample: expected a positive number of designs to re-simulate, found {sample}")
    path = Path(path)
    checked = read_record(path)
    record, settings, rule = checked.document, checked.settings, checked.rule
    table = read_table(path, "modular_exhaustive")
    simulated = table[table.sim_steps > 0]
    if simulated.empty:
        raise ArtifactError(f"{path}: no simulated design (sim_steps > 0) to re-simulate")
    rows = simulated.sample(n=min(sample, len(simulated)), random_state=seed).sort_values("design")
    results = evaluate_designs(list(rows.design), int(rows.terrain_seed.iloc[0]), settings, rule, None, executor)
    mismatches = [row.design for row, result in zip(rows.itertuples(), results, strict=True)
                  if (result.status, result.sim_steps) != (row.status, row.sim_steps)
                  or not _same_distance(result.distance, row.distance)]
    current = physics_digest()
    report = {"table": str(path), "sample": len(rows), "mismatches": mismatches,
              "stored_digest": record["physics_digest"], "current_digest": current, "rekeyed": False}
    if rekey and not mismatches and record["physics_digest"] != current:
        atomic_write_json(path.with_suffix(".json"), {**record, "physics_digest": current,
                                                      "verified": {"sample": len(rows), "seed": seed,
                                                                   "from_digest": record["physics_digest"]}})
        report["rekeyed"] = True
    return report


def _same_distance(measured: float | None, stored: float) -> bool:
    """Bit-for-bit equal distances (a missing distance is null in a result and NaN in a table)."""
    if measured is None:
        return stored != stored
    return float(measured).hex() == float(stored).hex()


def canonical(design: str) -> str:
    """One name per mirror pair (the smaller of the design and its mirror)."""
    return min(design, mirror(design))


def truth_summary(table: pd.DataFrame, epsilon: float) -> pd.DataFrame:
    """Per terrain: the optimum, its design, the near-optimal designs (within epsilon) and how many there are."""
    rows = []
    for terrain_seed, group in table.groupby("terrain_seed", sort=True):
        best = group.fitness.max()
        near = group[group.fitness >= best - epsilon].sort_values(["fitness", "design"], ascending=[False, True])
        rows.append({"terrain_seed": int(terrain_seed), "optimum": float(best),
                     "best_design": near.design.iloc[0], "near_optimal": len(near),
                     "near_optimal_designs": " ".join(near.design.head(8)),
                     "simulated": int((group.sim_steps > 0).sum())})
    return pd.DataFrame(rows)


def terrain_criterion(table: pd.DataFrame) -> tuple[pd.DataFrame, dict]:
    """Per terrain (optimum design and distance, the best-on-average design's distance and regret) and totals.

    The best design on average is the one with the highest mean distance over the terrains among designs that
    carry a distance on every terrain (a penalty is never averaged as a distance). Totals: the number of distinct
    optimal designs up to mirror symmetry, the mean optimum, the best-on-average design's mean regret, its
    ratio to the mean optimum, and `holds`: whether they meet `CRITERION`.
    """
    distances = table.pivot(index="design", columns="terrain_seed", values="distance")  # (designs, terrains)
    complete = distances.dropna()
    if complete.empty:
        raise ValueError("terrain criterion: no design carries a distance on every terrain")
    means = complete.mean(axis=1)
    average = means[means == means.max()].index.min()  # ties: the first port string
    rows = []
    for seed in distances.columns:
        column = distances[seed].dropna()
        optimum = column.max()
        best = column[column == optimum].index.min()
        rows.append({"terrain_seed": int(seed), "optimum_design": best, "optimum": float(optimum),
                     "average_design": average, "average_distance": float(complete.loc[average, seed]),
                     "regret": float(optimum - complete.loc[average, seed])})
    per_terrain = pd.DataFrame(rows)
    mean_optimum = float(per_terrain.optimum.mean())
    totals = {"terrains": len(per_terrain),
              "distinct_optima": int(per_terrain.optimum_design.map(canonical).nunique()),
              "average_design": average, "mean_optimum": mean_optimum,
              "mean_regret": float(per_terrain.regret.mean()),
              "regret_ratio": float(per_terrain.regret.mean() / mean_optimum) if mean_optimum > 0 else float("nan")}
    totals["holds"] = bool(totals["terrains"] >= CRITERION["terrains"]
                           and totals["distinct_optima"] >= CRITERION["distinct_optima"]
                           and totals["regret_ratio"] >= CRITERION["regret_ratio"])
    return per_terrain, totals


def exhaustive_metrics(table: pd.DataFrame, sources: dict[int, str], near_optimal: float,
                       terrain: TerrainConfig) -> dict:
    """reports/metrics/modular_exhaustive.json: per terrain its optimum, best design, near-optimal designs,
    simulated designs and tallest block; the terrain criterion; what the tables cost and where they came from."""
    summary = truth_summary(table, near_optimal)
    per_terrain, totals = terrain_criterion(table)

    def rounded(row: dict) -> dict:
        return {k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()}

    return {
        "optimum": {str(r.terrain_seed): round(r.optimum, 4) for r in summary.itertuples()},
        "best_design": {str(r.terrain_seed): r.best_design for r in summary.itertuples()},
        "near_optimal": {str(r.terrain_seed): r.near_optimal for r in summary.itertuples()},
        "simulated": {str(r.terrain_seed): r.simulated for r in summary.itertuples()},
        "tallest_block_cm": {str(r.terrain_seed): round(generate_terrain(r.terrain_seed, terrain).max_height * 100, 1)
                             for r in summary.itertuples()},
        "source": {str(seed): source for seed, source in sources.items()},
        "criterion": {**rounded(totals), "per_terrain": [rounded(row) for row in per_terrain.to_dict("records")]},
        "simulation_cpu_seconds": round(float(table.seconds.sum()), 1),
        "statuses": table.status.value_counts().sort_index().to_dict()}


def pool_metrics(table: pd.DataFrame, splits: dict[str, list[int]], sizes: list[int]) -> dict:
    """reports/metrics/modular_pool.json: per split of the training pool (training, validation terrains) its
    distinct optima up to mirror, best-on-average design and that design's regret (`terrain_criterion`), and the
    same for the first `sizes` training terrains (how the best fixed design changes as the pool grows)."""

    def criterion(seeds: list[int]) -> dict:
        per_terrain, totals = terrain_criterion(table[table.terrain_seed.isin(seeds)])
        return {**{k: round(v, 4) if isinstance(v, float) else v for k, v in totals.items() if k != "holds"},
                "optimum_designs": dict(zip(per_terrain.terrain_seed.astype(str), per_terrain.optimum_design,
                                            strict=True))}

    train = splits["training"]
    return {**{name: {"seeds": [min(seeds), max(seeds)], **criterion(seeds)} for name, seeds in splits.items()},
            "by_size": {str(n): criterion(train[:n]) for n in sizes if n <= len(train)},
            "simulated_designs": int((table.sim_steps > 0).sum())}
