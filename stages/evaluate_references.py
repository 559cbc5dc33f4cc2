"""DVC stage `evaluate_references`: the RoboGrammar reference designs and random dataset designs on every task.

params (compute, evaluation, evaluate_references) + data/designs.parquet -> data/reference_evals.parquet,
data/rollouts/<task>.{mcap,gif} (best design of each task), reports/metrics/evaluate_references.json. Evaluations of
today's settings and code committed under measured/references/ are served, not simulated (their count goes to
reports/timings.json).
"""

from pathlib import Path

from robocompose.evaluation.evaluate import EvaluationConfig
from robocompose.evaluation.references import (
    ReferencesConfig,
    best_per_task,
    best_scores,
    committed_evaluations,
    evaluate_references,
    record_best,
    table_keys,
)
from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.io.timings import timed
from robocompose.params import load_section
from robocompose.stage import run_stage


def main() -> None:
    evaluation = load_section(EvaluationConfig, "evaluation")
    config = load_section(ReferencesConfig, "evaluate_references")
    compute = load_section(ComputeConfig, "compute")
    designs = read_table("data/designs.parquet", "designs")
    with timed("evaluate_references") as timing, compute.executor("evaluate_references") as executor:
        cache, committed = compute.open_cache(), committed_evaluations()
        cache.merge(committed)
        table = evaluate_references(designs, config, evaluation, cache, executor, save_every=8)
        timing["evaluations"] = len(table)
        timing["committed_evaluations"] = sum(key in committed for key in table_keys(table))
        timing["sim_steps"] = int(table["sim_steps"].sum())
        write_table(table, "data/reference_evals.parquet", "reference_evals")
        record_best(table, designs, config, evaluation, Path("data/rollouts"), executor=executor)
        best = best_per_task(table)
        atomic_write_json("reports/metrics/evaluate_references.json", {
            "best_reward": {row.task: round(row.reward, 4) for row in best.itertuples()},
            "best_design": {row.task: row.name for row in best.itertuples()},
            "best_score": best_scores(table),
            "statuses": table["status"].value_counts().sort_index().to_dict(),
            "settings_hash": {task: evaluation.settings_hash(task) for task in config.tasks}})


if __name__ == "__main__":
    run_stage(main)
