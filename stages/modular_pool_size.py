"""DVC stage `modular_pool_size`: held-out score against the training pool's size (beyond the thesis), for
EG-GAN-crowding and the terrain-agnostic portfolio (`robocompose.modular.experiments.pool_size`).

params (compute, modular, eggan_modular) + data/modular/pool.parquet + data/modular/exhaustive.parquet ->
data/modular/pool_size.parquet (every test query per pool size), reports/metrics/modular_pool_size.json (per size and
method: mean max distance and regret on the test terrains, max distance on the training terrains). The runs go to
the compute workers; each resumes from its checkpoint (models/checkpoints/pool_size/).
"""

from pathlib import Path

from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.io.timings import timed
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.experiments.pool_size import pool_size_study
from robocompose.modular.params import ModularParams
from robocompose.params import load_section
from robocompose.stage import run_stage


def main() -> None:
    modular, params = load_section(ModularParams, "modular"), load_section(EgganModularParams, "eggan_modular")
    pool = read_table(params.fitness.pool, "modular_exhaustive")
    truth = read_table("data/modular/exhaustive.parquet", "modular_exhaustive")
    compute = load_section(ComputeConfig, "compute")
    with timed("modular_pool_size"), compute.executor("modular_pool_size") as executor:
        table = pool_size_study(modular, params, params.pool_size, pool, truth, Path("models/checkpoints/pool_size"),
                                executor)
    write_table(table, "data/modular/pool_size.parquet", "modular_pool_size")
    means = table.groupby(["pool_terrains", "method"])[["max_distance", "regret", "train_max_distance"]].mean().round(4)
    atomic_write_json("reports/metrics/modular_pool_size.json", {
        str(n): {method: means.loc[(n, method)].to_dict() for method in table.method.unique()}
        for n in sorted(table.pool_terrains.unique())})


if __name__ == "__main__":
    run_stage(main)
