"""DVC stage `modular_exhaustive`: every modular design on every truth terrain (the ground truth), and the terrain
criterion (does the best design depend on the terrain?).

params (compute, modular) + reports/modular/exhaustive/ (committed one-offs) -> data/modular/exhaustive.parquet,
reports/metrics/modular_exhaustive.json. A terrain whose committed table was measured under the current settings,
fitness rule and physics code is read from it; any other is simulated through the shared cache (saved every 32
results, so an interrupted run resumes).
"""

from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json, write_table
from robocompose.modular.params import ModularParams
from robocompose.modular.truth import terrain_criterion, truth_summary, truth_tables
from robocompose.params import load_section
from robocompose.report.timings import timed
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
    summary = truth_summary(table, params.experiments.near_optimal)
    per_terrain, totals = terrain_criterion(table)
    atomic_write_json("reports/metrics/modular_exhaustive.json", {
        "optimum": {str(r.terrain_seed): round(r.optimum, 4) for r in summary.itertuples()},
        "best_design": {str(r.terrain_seed): r.best_design for r in summary.itertuples()},
        "near_optimal": {str(r.terrain_seed): r.near_optimal for r in summary.itertuples()},
        "source": {str(seed): source for seed, source in sources.items()},
        "criterion": {**{k: round(v, 4) if isinstance(v, float) else v for k, v in totals.items()},
                      "per_terrain": [{k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()}
                                      for row in per_terrain.to_dict("records")]},
        "simulation_cpu_seconds": round(float(table.seconds.sum()), 1),
        "statuses": table.status.value_counts().sort_index().to_dict(),
        "settings_hash": params.eval.settings_hash()})


if __name__ == "__main__":
    run_stage(main)
