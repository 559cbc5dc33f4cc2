"""Exhaustive ground truth of the modular world: every design on a terrain, and the terrain criterion.

- `exhaustive_terrain`: all 4096 port strings on one terrain under the fitness rule (the 1296 designs the original
  accepts simulated, the rest scored by the rule), through the shared cache, so a long table resumes.
- Committed one-offs: a table is also kept under `reports/modular/exhaustive/blocks-<seed>.parquet` with a JSON
  record of the settings, fitness rule and physics code it was measured with. The `modular_exhaustive` stage
  uses such a table when all three match the current ones, and simulates otherwise (a changed profile, e.g.
  `paper`, regenerates its own).
- `terrain_criterion`: does the best design depend on the terrain? Per terrain its optimum, the single design
  best on average over the terrains, and that design's regret; the count of distinct optima up to the
  left-right mirror (thesis Fig. 5.1: near-flat ground favours wheels, rough ground other modules).
"""

from __future__ import annotations

import ast
import hashlib
import inspect
import json
import time
from dataclasses import asdict
from pathlib import Path

import pandas as pd

from robocompose.evaluation.cache import EvaluationCache
from robocompose.evaluation.executor import Executor
from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.io.atomic import read_json
from robocompose.io.provenance import module_path
from robocompose.modular import evaluate
from robocompose.modular.evaluate import EvalSettings, FitnessRule, evaluate_designs
from robocompose.modular.robot import all_designs

COMMITTED_DIR = Path("reports/modular/exhaustive")
# Issue 13's terrain criterion: on >= 8 terrains, >= 3 distinct optima (up to mirror) and the best-on-average
# design's mean regret >= 10% of the mean optimum.
CRITERION = {"terrains": 8, "distinct_optima": 3, "regret_ratio": 0.10}
# What decides a rollout besides its settings: the robot, the terrain, the gait and pybullet's settings (modules),
# and the episode loop of evaluate.py (functions: the rest of that file is caching and batching).
PHYSICS_MODULES = ("robocompose.modular.robot", "robocompose.modular.terrain", "robocompose.modular.controller",
                   "robocompose.sim.physics")
EPISODE_FUNCTIONS = ("rollout", "rollouts", "_episode", "_state", "up_z", "_stop_reason")


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


class _RolloutCode(ast.NodeTransformer):
    """Drops what cannot change the numbers of a rollout that runs to its end: docstrings, imports (the physics
    modules among them are digested themselves) and raise statements (error types and messages)."""

    def visit_Import(self, node: ast.AST) -> None:
        return None

    visit_ImportFrom = visit_Import

    def visit_Raise(self, node: ast.Raise) -> ast.Pass:
        return ast.Pass()

    def generic_visit(self, node: ast.AST) -> ast.AST:
        body = getattr(node, "body", None)
        if (isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and body
                and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)):
            node.body = body[1:]
        return super().generic_visit(node)


def _rollout_code(source: str) -> str:
    return ast.dump(_RolloutCode().visit(ast.parse(source)))  # no line numbers: comments and layout drop out


def physics_digest() -> str:
    """SHA-256 (16 hex digits) of the physics modules' code and the episode functions' code, as `_RolloutCode`
    keeps them: a change of layout, comments, docstrings, imports or error types keeps the digest."""
    sources = [module_path(name).read_text() for name in PHYSICS_MODULES]
    sources += [inspect.getsource(getattr(evaluate, name)) for name in EPISODE_FUNCTIONS]
    return hashlib.sha256("\0".join(_rollout_code(source) for source in sources).encode()).hexdigest()[:16]


def provenance(settings: EvalSettings, rule: FitnessRule) -> dict:
    """What a table's numbers depend on: the settings and rule (as plain JSON) and the physics code's digest."""
    return json.loads(json.dumps({"settings": asdict(settings), "fitness": asdict(rule),
                                  "physics_digest": physics_digest()}, sort_keys=True))


def committed_path(terrain_seed: int, directory: Path = COMMITTED_DIR) -> Path:
    return Path(directory) / f"blocks-{int(terrain_seed)}.parquet"


def write_committed(table: pd.DataFrame, settings: EvalSettings, rule: FitnessRule, seconds: float,
                    directory: Path = COMMITTED_DIR) -> Path:
    """Keep one terrain's table and its provenance record (`.json` beside it) under `directory`."""
    seeds = table.terrain_seed.unique()
    if len(seeds) != 1:
        raise ValueError(f"a committed table holds one terrain, found seeds {sorted(seeds)}")
    path = committed_path(int(seeds[0]), directory)
    write_table(table, path, "modular_exhaustive")
    atomic_write_json(path.with_suffix(".json"), {
        **provenance(settings, rule), "terrain_seed": int(seeds[0]), "designs": len(table),
        "simulated": int((table.sim_steps > 0).sum()), "wall_seconds": round(seconds, 1)})
    return path


def read_committed(terrain_seed: int, settings: EvalSettings, rule: FitnessRule,
                   directory: Path = COMMITTED_DIR) -> pd.DataFrame | None:
    """The committed table of `terrain_seed` if it was measured with these settings, rule and physics; else None."""
    path = committed_path(terrain_seed, directory)
    record = path.with_suffix(".json")
    if not (path.exists() and record.exists()):
        return None
    stored = read_json(record)
    if {k: stored.get(k) for k in ("settings", "fitness", "physics_digest")} != provenance(settings, rule):
        return None
    return read_table(path, "modular_exhaustive")


def truth_tables(terrain_seeds: list[int], settings: EvalSettings, rule: FitnessRule,
                 cache: EvaluationCache | None, executor: Executor | None,
                 directory: Path = COMMITTED_DIR) -> tuple[pd.DataFrame, dict[int, str]]:
    """The exhaustive table of every terrain (committed where it matches, else simulated) and each one's source."""
    frames, sources = [], {}
    for seed in terrain_seeds:
        table = read_committed(seed, settings, rule, directory)
        sources[int(seed)] = "committed" if table is not None else "simulated"
        if table is None:
            table = exhaustive_terrain(seed, settings, rule, cache, executor)
        frames.append(table)
    return pd.concat(frames, ignore_index=True).sort_values(["terrain_seed", "design"], ignore_index=True), sources


def measure_committed(terrain_seed: int, settings: EvalSettings, rule: FitnessRule, cache: EvaluationCache,
                      executor: Executor | None, directory: Path = COMMITTED_DIR) -> Path:
    """Simulate one terrain's table (resuming from the cache) and commit it under `directory`."""
    started = time.perf_counter()
    table = exhaustive_terrain(terrain_seed, settings, rule, cache, executor)
    cache.save()
    return write_committed(table, settings, rule, time.perf_counter() - started, directory)


def mirror(design: str) -> str:
    """The left-right mirror image: ports front-left..front-right reversed (front-left <-> front-right, ...)."""
    return design[::-1]


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
