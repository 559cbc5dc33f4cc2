"""DVC stage `modular_baselines`: GA-20, GA-50, GA-crowding and random sampling on every test terrain.

params (modular) + data/modular/exhaustive.parquet -> data/modular/runs.parquet, reports/metrics/modular_baselines.json.
The test terrains are all in the evaluation cache after `modular_exhaustive`, so the runs read their fitness from it;
each run's cost without a cache is its `sim_steps`.
"""

from robocompose.evaluation.cache import EvaluationCache
from robocompose.evaluation.executor import Executor
from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.modular.experiments import baseline_runs
from robocompose.modular.params import load_modular_params
from robocompose.report.timings import timed
from robocompose.stage import run_stage


def main() -> None:
    params = load_modular_params("params.yaml")
    truth = read_table("data/modular/exhaustive.parquet", "modular_exhaustive")
    cache = EvaluationCache(params.cache or None)
    with timed("modular_baselines") as timing, Executor(params.workers, params.address or None) as executor:
        runs = baseline_runs(params, truth, cache, executor)
        timing["runs"] = len(runs)
    write_table(runs, "data/modular/runs.parquet", "modular_runs")
    runs["regret"] = runs.optimum - runs.best_fitness
    means = runs.groupby("method")[["best_fitness", "distinct", "regret", "ec_fitness"]].mean().round(4)
    atomic_write_json("reports/metrics/modular_baselines.json", {
        method: row.to_dict() for method, row in means.iterrows()})


if __name__ == "__main__":
    run_stage(main)
