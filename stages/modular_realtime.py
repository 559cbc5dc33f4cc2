"""DVC stage `modular_realtime`: the real-time test protocol of thesis Table 5.1 on the held-out test terrains.

params (modular, eggan_modular) + the generators of `train_eggan_modular` + the test terrains' tables: the
exhaustive one (data/modular/exhaustive.parquet) where a terrain has it, else its committed partial table
(measured/modular/test_partial/, `held_out`) + the training pool's tables (data/modular/pool.parquet, stage
modular_pool; its training terrains give the portfolios, top-k and greedy, and the rows from which the predict rows
predict a test terrain's row of the table from its height map) -> data/modular/realtime.parquet,
reports/metrics/modular_realtime.json (per method, with its title and whether it is learned: the report reads
them there; the best of the first 1, 3 and 10 candidates per method and terrain; the portfolios' designs; the
predict rows' settings; DQN's symmetric-space ceiling on the test terrains with a full table; each test terrain's
table, and the candidates simulated outside the partial ones), and Fig. 5.1's designs on the first two test
terrains (data/modular/fig5_1.json). Every candidate is answered from the test terrain's table: no rollout on a
full one; outside a partial one, a rollout through the shared cache (params compute), unless it is committed in
measured/modular/test_partial/outside.parquet; every one the run needed goes to data/modular/outside_rollouts.parquet
(copy it there and commit it, and a fresh clone's run simulates none). A test terrain without a
table stops the stage before any work with one line naming it and the command that measures it.

Further training seeds: every folder measured/modular/seeds/seed-S (`robocompose modular train-seed`) answers the
learned rows again, on the same terrains, queries and candidates (column `training_seed`; the stage's own models
and the unlearned rows, answered once, carry the learners' configured seed and 0). A folder whose models were
trained under other settings, lack a learner or repeat a learner's own seed stops the stage before any work
(`training_seeds.further_seeds`). The metrics give each learned row's mean and sd over its training seeds
(`training_seeds`); their other numbers pool every seed's queries.
"""

from contextlib import nullcontext
from pathlib import Path

from robocompose.eggan.query import load_generator
from robocompose.fanout.cache import EvaluationCache, committed_cache
from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.io.timings import timed
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.experiments.figure_5_1 import figure_5_1
from robocompose.modular.experiments.generative import (
    learned_methods,
    make_problem,
    method_info,
    realtime_proposers,
    seeded_realtime_table,
)
from robocompose.modular.experiments.held_out import (
    FULL,
    OUTSIDE,
    OUTSIDE_OUT,
    held_out_metrics,
    held_out_tables,
    outside_rollouts,
)
from robocompose.modular.experiments.protocol import (
    TableAnswers,
    best_of_columns,
    best_of_ks,
    best_of_summary,
    seed_summary,
    summarise,
)
from robocompose.modular.experiments.table_designs import (
    greedy_portfolio,
    pool_rows,
    portfolio,
    predict_proposers,
    symmetric_ceiling,
    terrain_features,
    top_designs,
)
from robocompose.modular.experiments.training_seeds import further_seeds
from robocompose.modular.gate import GateConfig
from robocompose.modular.params import ModularParams
from robocompose.params import load_section
from robocompose.stage import run_stage

EXHAUSTIVE = Path("data/modular/exhaustive.parquet")
FIG_5_1_GENERATOR = Path("models/eggan_modular_crowding.pt")
SEEDS = Path("measured/modular/seeds")  # further training seeds: seed-S/eggan_modular_NAME.pt per learner
PREDICT = GateConfig()  # the predict rows' k-NN neighbours and ridge penalty: the gate's


def main() -> None:
    modular, params = load_section(ModularParams, "modular"), load_section(EgganModularParams, "eggan_modular")
    compute = load_section(ComputeConfig, "compute")
    seeds = further_seeds(SEEDS, modular, params)  # every folder checked first: a stale seed stops the stage here
    fitness, protocol = params.fitness, params.protocol
    test, sources = held_out_tables(protocol.test_terrains, read_table(EXHAUSTIVE, "modular_exhaustive"),
                                    modular.eval, modular.fitness)
    pool = read_table(fitness.pool, "modular_exhaustive")
    training = pool[pool.terrain_seed.isin(fitness.train_seeds)]
    designs, greedy = portfolio(training, protocol.candidates), greedy_portfolio(training, protocol.candidates)
    optima = {int(seed): top_designs(table, protocol.candidates) for seed, table in test.groupby("terrain_seed")}
    partial = [seed for seed, source in sources.items() if source != FULL]
    # workers only where a candidate may need a rollout: full tables answer every design
    with timed("modular_realtime") as timing, \
            (compute.executor("modular_realtime") if partial else nullcontext()) as executor:
        problem = make_problem(modular, params, None, None)  # task encodings only: nothing is simulated
        predict = predict_proposers(problem, training, PREDICT)
        proposers = realtime_proposers(problem, params, Path("models"), designs, optima, greedy, predict)
        ks = best_of_ks(protocol.candidates)
        cache = compute.open_cache() if partial else EvaluationCache()
        cache.merge(committed_cache(OUTSIDE))  # the committed rollouts outside the partial tables: not simulated
        answers = TableAnswers(test, modular.eval, modular.fitness, cache, executor)
        table, timing["query_ms_median"] = seeded_realtime_table(proposers, seeds, problem, modular, params,
                                                                 answers, ks)
        timing["queries"] = len(table)
        fig_5_1 = figure_5_1(load_generator(FIG_5_1_GENERATOR, problem)[0], problem, modular.fitness,
                             sorted(protocol.test_terrains)[:2])
    atomic_write_json("data/modular/fig5_1.json", fig_5_1)
    write_table(table.drop(columns=best_of_columns(ks)), "data/modular/realtime.parquet", "modular_realtime")
    write_table(outside_rollouts(answers, cache), OUTSIDE_OUT, "eval_cache")
    full = test[test.terrain_seed.map(sources) == FULL]  # a partial table holds too few symmetric designs
    ceiling = symmetric_ceiling(full) if not full.empty else {}
    over_seeds = seed_summary(table, learned_methods(), ks)
    atomic_write_json("reports/metrics/modular_realtime.json", {
        **{row["method"]: {**{k: (None if v != v else round(float(v), 4)) for k, v in row.items() if k != "method"},
                           **method_info(row["method"]),
                           **({"training_seeds": over_seeds[row["method"]]} if row["method"] in over_seeds else {})}
           for row in summarise(table).to_dict("records")},
        "further_training_seeds": list(seeds),
        "best_of": best_of_summary(table, ks),
        "diverse_query": {"min_hamming": protocol.diverse_hamming},
        "portfolio_designs": {"pool_terrains": len(fitness.train_seeds), "designs": designs, "greedy": greedy},
        "predict_table": {"pool_terrains": pool_rows(training).shape[0], "designs": pool_rows(training).shape[1],
                          "neighbours": PREDICT.neighbours, "ridge": PREDICT.ridge,
                          "features": list(terrain_features(problem, fitness.train_seeds[0]).index)},
        "dqn_symmetric_ceiling": {k: round(v, 4) if isinstance(v, float) else v for k, v in ceiling.items()},
        "test_tables": held_out_metrics(test, sources, answers)})


if __name__ == "__main__":
    run_stage(main)
