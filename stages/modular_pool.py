"""DVC stage `modular_pool`: the training pool's exact ground truth, every design on every pool terrain (thesis
5.1's training terrains, disjoint from the test terrains), for training every learner on exact fitness.

params (compute, modular, eggan_modular.fitness, eggan_modular.pool_size.sizes) + measured/modular/pool/
(committed tables) -> data/modular/pool.parquet, reports/metrics/modular_pool.json. A terrain whose committed
table was measured under the current settings, fitness rule and physics code is read from it; any other (the
paper profile's settings) is simulated through the shared cache, resumably.
"""

from pathlib import Path

from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json, write_table
from robocompose.io.timings import timed
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.params import ModularParams
from robocompose.modular.truth import pool_metrics, truth_tables
from robocompose.params import load_section
from robocompose.stage import run_stage


def main() -> None:
    modular, params = load_section(ModularParams, "modular"), load_section(EgganModularParams, "eggan_modular")
    fitness = params.fitness
    compute = load_section(ComputeConfig, "compute")
    cache = compute.open_cache()
    splits = {"training": fitness.train_seeds, "validation": fitness.validation_seeds}
    with timed("modular_pool") as timing, compute.executor("modular_pool") as executor:
        table, sources = truth_tables(splits["training"] + splits["validation"], modular.eval, modular.fitness, cache,
                                      executor, Path(fitness.pool_dir))
        timing["simulated_terrains"] = sum(source == "simulated" for source in sources.values())
    write_table(table, fitness.pool, "modular_exhaustive")
    atomic_write_json("reports/metrics/modular_pool.json", {**pool_metrics(table, splits, params.pool_size.sizes),
                                                             "sources": sorted(set(sources.values()))})


if __name__ == "__main__":
    run_stage(main)
