"""The test terrains' tables of Table 5.1 (issue 46, item 2: >= 30 test terrains without 30 exhaustive tables).

A test terrain is answered from its full exhaustive table (all 4096 designs: `modular.experiments.truth_terrains`,
stage `modular_exhaustive`) where it has one, else from a partial table: a design set (e.g. `family_truth`'s
"balanced" 400, which keeps the block test optimum 2.620 of 2.621 m on the 10 full tables) measured by
`robocompose modular exhaustive --design-set balanced` under `PARTIAL_DIR`, committed as the full ones are (same
provenance record, plus the design set's name and digest). A terrain with neither is refused, naming the command.

`protocol.TableAnswers` answers the protocol's candidates: from the table; a candidate outside a partial table is
simulated through the shared evaluation cache and executor (the real evaluator, never imputed) and counted. A
partial terrain's optimum is the best over its measured set and every design simulated for it: a lower bound on its
true optimum.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from robocompose.fanout.cache import EvaluationCache
from robocompose.io.errors import InputError
from robocompose.modular.evaluate import SEED, EvalSettings, FitnessRule, task_id
from robocompose.modular.experiments.protocol import TableAnswers
from robocompose.modular.truth import committed_path, read_committed, read_record

PARTIAL_DIR = Path("measured/modular/test_partial")
FULL = "full"  # a terrain's source when it has its exhaustive table
# committed rollouts of candidates outside the partial tables (eval_cache rows): a cache, so that a fresh clone's run
# does not simulate them again; what the stage simulates anew it writes to OUTSIDE_OUT, to be copied here
OUTSIDE = PARTIAL_DIR / "outside.parquet"
OUTSIDE_OUT = Path("data/modular/outside_rollouts.parquet")


def design_set_record(name: str, designs: Sequence[str]) -> dict:
    """What a partial table's record adds to a committed table's: which designs it holds (name, count, digest), so
    that a table of another set is re-measured rather than kept."""
    digest = hashlib.sha256(" ".join(sorted(designs)).encode()).hexdigest()[:16]
    return {"design_set": name, "design_set_size": len(designs), "design_set_digest": digest}


def read_partial(terrain_seed: int, settings: EvalSettings, rule: FitnessRule, directory: Path = PARTIAL_DIR,
                 design_set: dict | None = None) -> pd.DataFrame | None:
    """The partial table of `terrain_seed` under `directory` if it was measured with these settings, rule and physics
    (and, given `design_set`, that `design_set_record`); else None."""
    table = read_committed(terrain_seed, settings, rule, directory)
    if table is None or design_set is None:
        return table
    document = read_record(committed_path(terrain_seed, directory)).document
    return table if all(document.get(k) == v for k, v in design_set.items()) else None


def held_out_tables(seeds: Sequence[int], full: pd.DataFrame, settings: EvalSettings, rule: FitnessRule,
                directory: Path = PARTIAL_DIR) -> tuple[pd.DataFrame, dict[int, str]]:
    """The table of every test terrain (full from `full` where it is there, else its partial table under
    `directory`) and each terrain's source (`FULL` or the partial table's design set). Every terrain is checked
    before any is used: one without a table is an InputError naming it and the command that measures it."""
    frames, sources = [], {}
    for seed in seeds:
        table = full[full.terrain_seed == seed]
        if table.empty:
            table = read_partial(seed, settings, rule, directory)
            if table is None:
                raise InputError(
                    f"eggan_modular.protocol.test_terrains: terrain {seed} has no table measured under the current "
                    f"settings (neither in modular.experiments.truth_terrains nor under {directory}); expected one: "
                    f"robocompose modular exhaustive --terrain-seed {seed} --design-set balanced")
            sources[int(seed)] = str(read_record(committed_path(seed, directory)).document.get("design_set", FULL))
        else:
            sources[int(seed)] = FULL
        frames.append(table)
    return pd.concat(frames, ignore_index=True), sources


def outside_rollouts(answers: TableAnswers, cache: EvaluationCache) -> pd.DataFrame:
    """The eval_cache rows (from `cache`, which answered them) of every candidate `answers` simulated outside the
    partial tables, sorted by key: what OUTSIDE holds once committed."""
    settings_hash = answers.settings.settings_hash()
    kept = EvaluationCache()
    for seed, designs in answers.simulated.items():
        for design in designs:
            key = (design, task_id(seed), settings_hash, SEED)
            kept.put(key, **cache.get(key))
    return kept.frame()


def held_out_metrics(truth: pd.DataFrame, sources: dict[int, str], answers: TableAnswers) -> dict:
    """reports/metrics/modular_realtime.json's `test_tables`: the terrains with a full table; per partial one its
    design set, designs measured, the set's optimum, the optimum with every simulated candidate (the report's
    lower bound) and the candidates simulated outside it; their total."""
    sizes = truth.groupby("terrain_seed").size()
    partial = {str(seed): {"design_set": source, "designs": int(sizes[seed]),
                           "table_optimum": round(answers.table_optimum[seed], 4),
                           "optimum": round(answers.optimum(seed), 4), "rollouts": answers.rollouts[seed]}
               for seed, source in sources.items() if source != FULL}
    return {"full": [seed for seed, source in sources.items() if source == FULL], "partial": partial,
            "rollouts_outside_tables": sum(answers.rollouts.values())}
