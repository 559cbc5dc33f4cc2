"""DVC stage `modular_exhaustive`: every modular design on every truth terrain (the ground truth), the terrain
criterion (does the best design depend on the terrain?), and a picture of the first terrains with their best designs.

params (compute, modular) + measured/modular/exhaustive/ (committed one-offs) -> data/modular/exhaustive.parquet,
reports/metrics/modular_exhaustive.json, reports/plots/modular_terrains.png. A terrain whose committed table was
measured under the current settings, fitness rule and physics code is read from it; any other is simulated through
the shared cache (saved every 32 results, so an interrupted run resumes).
"""

from pathlib import Path

from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json, write_table
from robocompose.io.timings import timed
from robocompose.modular.experiments.pictures import plot_terrains
from robocompose.modular.params import ModularParams
from robocompose.modular.truth import exhaustive_metrics, truth_summary, truth_tables
from robocompose.params import load_section
from robocompose.stage import run_stage


def main() -> None:
    params = load_section(ModularParams, "modular")
    compute = load_section(ComputeConfig, "compute")
    cache = compute.open_cache()
    with timed("modular_exhaustive") as timing, compute.executor("modular_exhaustive") as executor:
        table, sources = truth_tables(params.experiments.truth_terrains, params.eval, params.fitness, cache,
                                      executor)
        timing["simulated_terrains"] = sum(source == "simulated" for source in sources.values())
        timing["rollouts"] = int((table.sim_steps > 0).sum())
    write_table(table, "data/modular/exhaustive.parquet", "modular_exhaustive")
    metrics = exhaustive_metrics(table, sources, params.experiments.near_optimal, params.eval.terrain)
    atomic_write_json("reports/metrics/modular_exhaustive.json", {**metrics,
                                                                   "settings_hash": params.eval.settings_hash()})
    summary = truth_summary(table, params.experiments.near_optimal)
    plot_terrains(summary.head(params.experiments.gallery), params, Path("reports/plots/modular_terrains.png"))


if __name__ == "__main__":
    run_stage(main)
