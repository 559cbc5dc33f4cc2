"""The real-time protocol answers every candidate from the test terrains' tables: no rollout; the oracle rows
score the optimum; the portfolio gives the same designs on every terrain; a terrain without a table is an error;
the best of the first k candidates is read from the same candidates."""

import numpy as np
import pandas as pd
import pytest

from robocompose.io.errors import InputError
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.experiments.generative import make_problem
from robocompose.modular.experiments.protocol import (
    TableAnswers,
    best_of_columns,
    best_of_ks,
    best_of_summary,
    random_proposer,
    realtime_table,
    seed_summary,
    table_proposers,
    terrain_means,
)
from robocompose.modular.experiments.table_designs import top_designs
from robocompose.params import build_config
from tests.modular.experiments.test_generative import MODULAR, SECTION


def answered(truth: pd.DataFrame) -> TableAnswers:
    return TableAnswers(truth, MODULAR.eval, MODULAR.fitness)


def test_the_protocol_answers_from_the_tables_with_the_portfolio_and_the_oracle(fake_rollouts, synthetic_truth):
    # the best design depends on the terrain: wheels on 1007, legs on 1008 (fewer distances on 1008)
    truth = pd.concat([synthetic_truth(lambda d: float(d.count("w")), 1007),
                       synthetic_truth(lambda d: d.count("l") / 2, 1008)], ignore_index=True)
    params = build_config(EgganModularParams, {**SECTION, "protocol": {"test_terrains": [1007, 1008], "queries": 2,
                                                                       "candidates": 4, "ec_draws": 3}}, "test")
    chosen = ["lwlwlw", "bwbbwb", "wlwwlw", "lllwll"]  # a portfolio as the pool would pick it
    optima = {seed: top_designs(table, 4) for seed, table in truth.groupby("terrain_seed")}
    proposers = {"random": random_proposer, **table_proposers(chosen, optima, chosen[::-1])}
    problem = make_problem(MODULAR, params, None, None)
    table, query_ms = realtime_table(proposers, problem, MODULAR, params, answered(truth))
    assert fake_rollouts == [] and set(query_ms) == {"random", "portfolio", "portfolio_greedy", "optimum"}
    assert len(table) == 4 * 2 * 2  # no rollout: tables only
    optimum = table[table.method == "optimum"].groupby("terrain_seed")
    assert optimum.max_distance.max().to_dict() == truth.groupby("terrain_seed").distance.max().to_dict() == \
        optimum.max_distance.min().to_dict() == {1007: 6.0, 1008: 3.0}
    assert (table[table.method == "optimum"].regret == 0).all()
    assert set(table[table.method == "optimum"].best_design) == {"wwwwww", "llllll"}  # the terrain's own optimum
    folio = table[table.method == "portfolio"]
    assert set(folio.best_design) == {"wlwwlw", "lllwll"}  # the same designs on both terrains, each best on one
    assert (folio.set_index(["terrain_seed", "query"]).regret > 0).all()
    greedy = table[table.method == "portfolio_greedy"]  # the same designs in its own order: the same best
    assert greedy.best_design.tolist() == folio.best_design.tolist()
    with pytest.raises(InputError, match=r"protocol.test_terrains: .* missing \[1008\]"):
        realtime_table(proposers, problem, MODULAR, params, answered(truth[truth.terrain_seed == 1007]))


def test_the_best_of_the_first_k_candidates_comes_from_the_same_candidates(synthetic_truth):
    truth = pd.concat([synthetic_truth(lambda d: float(d.count("w")), 1007),
                       synthetic_truth(lambda d: d.count("l") / 2, 1008)], ignore_index=True)
    params = build_config(EgganModularParams, {**SECTION, "protocol": {"test_terrains": [1007, 1008], "queries": 2,
                                                                       "candidates": 4, "ec_draws": 3}}, "test")
    assert best_of_ks(10) == (1, 3, 10) and best_of_ks(3) == (1, 3) and best_of_ks(1) == (1,)
    chosen = ["lwlwlw", "bwbbwb", "wlwwlw", "lllwll"]  # wheels (1007): 3, 2, 4, 1; legs / 2 (1008): 1.5, 0, 1, 2.5
    ks = best_of_ks(4)
    problem = make_problem(MODULAR, params, None, None)
    table, _ = realtime_table({"portfolio": table_proposers(chosen, {})["portfolio"], "random": random_proposer},
                              problem, MODULAR, params, answered(truth), ks)
    folio = table[table.method == "portfolio"].set_index("terrain_seed")
    assert folio.loc[1007, "best_of_1"].tolist() == [3.0, 3.0] and folio.loc[1007, "best_of_3"].tolist() == [4.0, 4.0]
    assert folio.loc[1008, "best_of_3"].tolist() == [1.5, 1.5] and folio.loc[1008, "best_of_4"].tolist() == [2.5, 2.5]
    assert table.best_of_4.fillna(-1).tolist() == table.max_distance.fillna(-1).tolist()  # NaN: none valid
    assert (folio.lookups_3 == 3).all() and table.lookups_3.between(1, 3).all()  # random draws may repeat
    best = table[["best_of_1", "best_of_3", "best_of_4"]].fillna(-1)
    assert (best.best_of_1 <= best.best_of_3).all() and (best.best_of_3 <= best.best_of_4).all()
    summary = best_of_summary(table, ks)
    assert summary["ks"] == [1, 3, 4]
    assert summary["methods"]["portfolio"]["3"] == {"mean": 2.75, "std": 1.25, "no_valid": 0, "lookups": 3.0}
    assert summary["per_terrain"]["portfolio"]["1"] == {"1007": 3.0, "1008": 1.5}
    assert set(table.columns) - set(realtime_table({"random": random_proposer}, problem, MODULAR, params,
                                                   answered(truth))[0].columns) == set(best_of_columns(ks))


def _seeded_table() -> pd.DataFrame:
    """A hand-made realtime table: crowding at training seeds 0, 1, 2 on terrains 1000 and 1001 x 2 queries (seed 2
    has a query without a valid candidate), random answered once (training seed 0)."""
    scores = {0: {1000: [1.0, 2.0], 1001: [3.0, 4.0]}, 1: {1000: [2.0, 2.0], 1001: [2.0, 2.0]},
              2: {1000: [3.0, np.nan], 1001: [3.0, 3.0]}}
    rows = [{"method": "crowding", "training_seed": seed, "terrain_seed": terrain, "query": query, "max_distance": x,
             "distinct": seed + 1, "ec_distance": x, "regret": 5.0 - x, "best_of_1": x / 2, "lookups_1": 1}
            for seed, by_terrain in scores.items() for terrain, xs in by_terrain.items()
            for query, x in enumerate(xs)]
    rows += [{"method": "random", "training_seed": 0, "terrain_seed": terrain, "query": query, "max_distance": 1.0,
              "distinct": 1, "ec_distance": 1.0, "regret": 4.0, "best_of_1": 0.5, "lookups_1": 1}
             for terrain in (1000, 1001) for query in (0, 1)]
    return pd.DataFrame(rows)


def test_the_summary_over_training_seeds_is_the_mean_and_sd_of_the_seeds_means():
    table = _seeded_table()
    summary = seed_summary(table, ["crowding", "random"], (1,))
    crowding = summary["crowding"]
    assert crowding["seeds"] == [0, 1, 2] and crowding["n"] == 3
    # the seeds' means 2.5, 2.0, 3.0 (seed 2's invalid query left out): mean 2.5, sample sd 0.5; pooled over the
    # 11 valid queries the mean would be 27 / 11
    assert crowding["max_distance"] == {"mean": 2.5, "sd": 0.5, "per_seed": {"0": 2.5, "1": 2.0, "2": 3.0}}
    assert crowding["regret"] == {"mean": 2.5, "sd": 0.5, "per_seed": {"0": 2.5, "1": 3.0, "2": 2.0}}
    assert crowding["distinct"]["mean"] == 2.0 and crowding["distinct"]["sd"] == 1.0
    assert crowding["best_of_1"]["mean"] == 1.25 and crowding["best_of_1"]["sd"] == 0.25
    assert summary["random"]["n"] == 1 and summary["random"]["max_distance"] == {"mean": 1.0, "sd": None,
                                                                                "per_seed": {"0": 1.0}}
    assert set(seed_summary(table, ["crowding"])) == {"crowding"}  # only the methods asked for
    # a terrain's score for the paired tests: its mean over queries, averaged over the seeds
    means = terrain_means(table[table.method == "crowding"], "max_distance")
    assert means.to_dict() == pytest.approx({1000: (1.5 + 2.0 + 3.0) / 3, 1001: (3.5 + 2.0 + 3.0) / 3})
    summary = best_of_summary(table, (1,))
    assert summary["per_terrain"]["crowding"]["1"] == {"1000": round((0.75 + 1.0 + 1.5) / 3, 4),
                                                       "1001": round((1.75 + 1.0 + 1.5) / 3, 4)}
