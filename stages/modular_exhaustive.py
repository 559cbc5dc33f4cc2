"""DVC stage `modular_exhaustive`: all 4096 modular designs on every test terrain (the ground truth).

params (modular) -> data/modular/exhaustive.parquet, reports/metrics/modular_exhaustive.json. Evaluations go
through the shared cache (saved every 32 results), so an interrupted run resumes where it stopped.
"""

from robocompose.evaluation.cache import EvaluationCache
from robocompose.evaluation.executor import Executor
from robocompose.io import atomic_write_json, write_table
from robocompose.modular.experiments import exhaustive_table, truth_summary
from robocompose.modular.params import load_modular_params
from robocompose.report.timings import timed


def main() -> None:
    params = load_modular_params("params.yaml")
    cache = EvaluationCache(params.cache or None)
    with timed("modular_exhaustive") as timing, Executor(params.workers, params.address or None,
                                                         progress="modular_exhaustive") as executor:
        table = exhaustive_table(params, cache, executor)
        timing["simulated"] = int((table.sim_steps > 0).sum())
        timing["sim_steps"] = int(table.sim_steps.sum())
    write_table(table, "data/modular/exhaustive.parquet", "modular_exhaustive")
    summary = truth_summary(table, params.experiments.near_optimal)
    atomic_write_json("reports/metrics/modular_exhaustive.json", {
        "optimum": {str(r.terrain_seed): round(r.optimum, 4) for r in summary.itertuples()},
        "best_design": {str(r.terrain_seed): r.best_design for r in summary.itertuples()},
        "near_optimal": {str(r.terrain_seed): r.near_optimal for r in summary.itertuples()},
        "statuses": table.status.value_counts().sort_index().to_dict(),
        "settings_hash": params.eval.settings_hash()})


if __name__ == "__main__":
    main()
