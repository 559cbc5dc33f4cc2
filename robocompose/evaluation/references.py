"""Scoring the RoboGrammar reference designs and a few random dataset designs on every task.

This anchors the evaluator: the two designs RoboGrammar found best (on flat and on ridged terrain) should
beat random grammar designs on their own terrain. The best design of each task is replayed with a
`RolloutRecorder` into an MCAP log and a GIF.

The candidates' evaluations are deterministic and most of a fresh clone's stage time, so they are also a committed
measurement: `robocompose reference-evals` writes their cache entries to measured/references/eval_cache.parquet
(`commit_evaluations`) and the stage serves them from there (`committed_evaluations`). An entry's key carries the
settings hash, which covers the task, physics, MPPI settings and the code of an episode, so an entry of other
settings or code is never hit: such a run evaluates afresh. The replay of each task's best design checks the
served reward bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from robocompose.evaluation.evaluate import OK, EvalJob, EvaluationConfig, evaluate, evaluate_designs, objective
from robocompose.evaluation.rollout_log import RolloutRecorder
from robocompose.fanout.cache import EVAL_KEY_COLUMNS, EvaluationCache, committed_cache
from robocompose.fanout.executor import Executor
from robocompose.grammar.derivation import derive, parse_rules
from robocompose.grammar.references import REFERENCE_DESIGNS
from robocompose.grammar.tree import DesignTree
from robocompose.io import write_table
from robocompose.io.errors import InputError
from robocompose.sim.physics import PhysicsSettings
from robocompose.tasks.terrains import TASK_NAMES, get_task


@dataclass(frozen=True)
class ReferencesConfig:
    """The `evaluate_references:` section of params.yaml."""

    n_random: int = 8  # random dataset designs scored beside the reference designs
    seed: int = 0  # which random designs
    tasks: list[str] = field(default_factory=lambda: list(TASK_NAMES))

    def __post_init__(self) -> None:
        if self.n_random < 0:
            raise InputError(f"n_random: expected an integer >= 0, found {self.n_random}")
        for task in self.tasks:
            get_task(task)


def candidate_designs(designs: pd.DataFrame, config: ReferencesConfig) -> pd.DataFrame:
    """Columns name, design_id, rules, tree: the reference designs, then `n_random` dataset designs."""
    rows = []
    for name, text in REFERENCE_DESIGNS.items():
        rules = parse_rules(text)
        tree = derive(rules).tree
        rows.append({"name": name, "design_id": tree.design_id, "rules": list(rules), "tree": tree})
    if config.n_random > len(designs):
        raise InputError(f"evaluate_references.n_random = {config.n_random} but the dataset holds {len(designs)}")
    picks = np.random.default_rng(config.seed).choice(len(designs), size=config.n_random, replace=False)
    for k, i in enumerate(picks):
        row = designs.iloc[int(i)]
        tree = DesignTree(tuple(int(p) for p in row["parents"]), tuple(int(t) for t in row["tokens"]))
        rows.append({"name": f"random_{k}", "design_id": tree.design_id, "rules": [int(r) for r in row["rules"]],
                     "tree": tree})
    return pd.DataFrame(rows)


def evaluate_references(designs: pd.DataFrame, config: ReferencesConfig, evaluation: EvaluationConfig,
                        cache: EvaluationCache | None = None, executor: Executor | None = None,
                        save_every: int = 0) -> pd.DataFrame:
    """A `reference_evals` table: every candidate on every task with the evaluation seed."""
    candidates = candidate_designs(designs, config)
    rows = evaluate_designs(list(candidates["tree"]), config.tasks, evaluation, [evaluation.seed], cache, executor,
                            save_every)
    names = candidates.loc[candidates.index.repeat(len(config.tasks)), ["name", "rules"]].reset_index(drop=True)
    table = pd.concat([names, rows.drop(columns=["seconds"])], axis=1)
    table["objective"] = [objective(row) for row in table.to_dict("records")]
    return table


MEASURED = Path("measured/references/eval_cache.parquet")


def committed_evaluations(path: Path = MEASURED) -> EvaluationCache:
    """The committed evaluations at `path` (none if it is absent) as a memory-only cache."""
    return committed_cache(path)


def table_keys(table: pd.DataFrame) -> list[tuple]:
    """The cache key of every row of a `reference_evals` table."""
    return list(table[list(EVAL_KEY_COLUMNS)].itertuples(index=False, name=None))


def commit_evaluations(table: pd.DataFrame, cache: EvaluationCache, path: Path = MEASURED) -> Path:
    """Write `cache`'s entries of the table's rows to `path` (an eval_cache table sorted by key)."""
    kept = EvaluationCache()
    for key in table_keys(table):
        kept.put(key, **cache.get(key))
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    return write_table(kept.frame(), path, "eval_cache")


def best_per_task(table: pd.DataFrame) -> pd.DataFrame:
    """The row of the highest-reward ok design of each task (first in table order on ties)."""
    ok = table[table["status"] == OK]
    return ok.loc[ok.groupby("task", sort=False)["reward"].idxmax()]


def best_scores(table: pd.DataFrame) -> dict[str, dict[str, float]]:
    """The best objective score per task of the reference designs and of the random designs (`reference`,
    `random`): what an optimiser would see, penalties included."""
    scores = table.assign(score=[objective(r) for r in table.to_dict("records")])
    return {kind: {task: round(float(score), 4) for task, score in
                   scores[scores["name"].str.startswith(prefix)].groupby("task", sort=False)["score"].max().items()}
            for kind, prefix in (("reference", "robogrammar"), ("random", "random"))}


def record_rollout(job: tuple[EvalJob, tuple[int, int]]) -> tuple[dict, RolloutRecorder]:
    """Evaluate `job` again with a visual world and a recorder: (row, recorder). Runs in a worker."""
    job, gif_size = job
    recorder = RolloutRecorder(job.config.mppi.interval * PhysicsSettings().time_step, frame_every=2,
                               image_size=gif_size)
    return evaluate(job.tree, job.task, job.config, job.seed, observer=recorder, visual=True), recorder


def record_best(table: pd.DataFrame, designs: pd.DataFrame, config: ReferencesConfig, evaluation: EvaluationConfig,
                out_dir: Path, gif_size: tuple[int, int] = (320, 240), executor: Executor | None = None) -> list[Path]:
    """Replay the best design of each task into out_dir/<task>.mcap and out_dir/<task>.gif."""
    candidates = candidate_designs(designs, config)
    trees = dict(zip(candidates["name"], candidates["tree"], strict=True))
    best = best_per_task(table)
    jobs = [(EvalJob(trees[row.name], row.task, evaluation, int(row.seed)), gif_size) for row in best.itertuples()]
    replays = (executor or Executor(workers=1)).map(record_rollout, jobs)
    written = []
    for row, (replay, recorder) in zip(best.itertuples(), replays, strict=True):
        if replay["reward"] != row.reward:
            raise RuntimeError(f"{row.name} on {row.task}: replay scored {replay['reward']}, the table {row.reward}"
                               " (the simulation is not deterministic here)")
        written += [recorder.write_mcap(out_dir / f"{row.task}.mcap"), recorder.write_gif(out_dir / f"{row.task}.gif")]
    return written
