"""DVC stage `modular_realtime`: the real-time test protocol of thesis Table 5.1 on the held-out test terrains.

params (compute, modular, eggan_modular) + the generators of `train_eggan_modular` (+ the exhaustive table, for
regret) -> data/modular/realtime.parquet, reports/metrics/modular_realtime.json, and Fig. 5.1's designs on the
first two test terrains (data/modular/fig5_1.json). Every candidate is simulated through the shared evaluation cache.
"""

from pathlib import Path

from robocompose.eggan.query import load_generator
from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.io.timings import timed
from robocompose.modular.eggan_experiments import make_problem, realtime_proposers, realtime_table, summarise
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.figure_5_1 import figure_5_1
from robocompose.modular.params import ModularParams
from robocompose.params import load_section
from robocompose.stage import run_stage

EXHAUSTIVE = Path("data/modular/exhaustive.parquet")
FIG_5_1_GENERATOR = Path("models/eggan_modular_crowding.pt")


def main() -> None:
    modular, params = load_section(ModularParams, "modular"), load_section(EgganModularParams, "eggan_modular")
    truth = read_table(EXHAUSTIVE, "modular_exhaustive") if EXHAUSTIVE.exists() else None
    compute = load_section(ComputeConfig, "compute")
    cache = compute.open_cache()
    with timed("modular_realtime") as timing, compute.executor() as executor:
        problem = make_problem(modular, params, cache, executor)
        table, timing["query_ms_median"] = realtime_table(realtime_proposers(problem, params, Path("models")), problem,
                                                          modular, params, truth, cache, executor)
        timing["queries"] = len(table)
        fig_5_1 = figure_5_1(load_generator(FIG_5_1_GENERATOR, problem)[0], problem, modular.fitness,
                             sorted(params.protocol.test_terrains)[:2])
    atomic_write_json("data/modular/fig5_1.json", fig_5_1)
    write_table(table, "data/modular/realtime.parquet", "modular_realtime")
    summary = summarise(table)
    atomic_write_json("reports/metrics/modular_realtime.json", {
        row["method"]: {k: (None if v != v else round(float(v), 4)) for k, v in row.items() if k != "method"}
        for row in summary.to_dict("records")})


if __name__ == "__main__":
    run_stage(main)
