"""DVC stage `modular_baselines`: GA-20, GA-50, GA-crowding and random sampling on every test terrain (thesis
Table 5.2; the default profile: the 10 committed terrains 1000-1009 x 3 seeds, ~10 s on 2 busy cores).

params (modular) + data/modular/exhaustive.parquet -> data/modular/runs.parquet, reports/metrics/modular_baselines.json
(each method's means and its title).
Every fitness is read from the test terrain's exhaustive table (the simulator's measured result for every design);
each run's runtime is the measured simulation time of the evaluations it asked for (its cost without a cache).
"""

from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.io.timings import timed
from robocompose.modular.experiments.baselines import METHODS, baseline_runs
from robocompose.modular.params import ModularParams
from robocompose.params import load_section
from robocompose.stage import run_stage


def main() -> None:
    params = load_section(ModularParams, "modular")
    truth = read_table("data/modular/exhaustive.parquet", "modular_exhaustive")
    with timed("modular_baselines") as timing:
        runs = baseline_runs(params, truth)
        timing["runs"] = len(runs)
    write_table(runs, "data/modular/runs.parquet", "modular_runs")
    runs["regret"] = runs.optimum - runs.best_distance
    means = runs.groupby("method")[["best_distance", "distinct", "regret", "ec_distance", "sim_seconds"]].mean()
    failures = runs.groupby("method")[["ec_failures"]].sum().join(
        runs.best_distance.isna().groupby(runs.method).sum().rename("failed_runs"))
    atomic_write_json("reports/metrics/modular_baselines.json", {  # with each method's title: the report names it
        method: {**means.loc[method].round(4).to_dict(), **{k: int(v) for k, v in failures.loc[method].items()},
                 "title": METHODS[method]}
        for method in means.index})


if __name__ == "__main__":
    run_stage(main)
