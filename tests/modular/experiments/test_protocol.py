"""The real-time protocol answers every candidate from the test terrains' tables: no rollout; the oracle rows
score the optimum; the portfolio gives the same designs on every terrain; a terrain without a table is an error."""

import pandas as pd
import pytest

from robocompose.io.errors import InputError
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.experiments.generative import make_problem
from robocompose.modular.experiments.protocol import random_proposer, realtime_table, table_proposers
from robocompose.modular.experiments.table_designs import top_designs
from robocompose.params import build_config
from tests.modular.experiments.test_generative import MODULAR, SECTION


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
    table, query_ms = realtime_table(proposers, problem, MODULAR, params, truth)
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
        realtime_table(proposers, problem, MODULAR, params, truth[truth.terrain_seed == 1007])
