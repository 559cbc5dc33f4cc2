"""Designs chosen from exhaustive tables: the portfolio is best on average (not the per-terrain optima), the greedy
portfolio's best-of-k is best on average (it covers the terrains the top-k loses), the optimum rows are a
terrain's fittest designs, the symmetric ceiling equals a brute force over DQN's space."""

import numpy as np
import pandas as pd
import pytest

from robocompose.io.errors import InputError
from robocompose.modular.experiments.table_designs import (
    greedy_portfolio,
    portfolio,
    symmetric_ceiling,
    top_designs,
)
from robocompose.modular.plugins.eggan_problem import ModularEgganProblem
from robocompose.modular.robot import all_designs
from tests.modular.test_truth import _table


def test_the_portfolio_is_best_on_average_not_the_per_terrain_optima():
    table = _table({  # optima: wwwwww on 1, llllll on 2, lwwwww on 3; bbbbbb is never the optimum
        1: {"wwwwww": 9.0, "llllll": 1.0, "lwwwww": 4.0, "bbbbbb": 5.0, "bbbbbw": 5.0, "wbbbbb": 9.0},
        2: {"wwwwww": 0.0, "llllll": 9.0, "lwwwww": 4.0, "bbbbbb": 5.0, "bbbbbw": 5.0, "wbbbbb": None},
        3: {"wwwwww": 1.0, "llllll": 1.0, "lwwwww": 9.0, "bbbbbb": 5.0, "bbbbbw": 5.0, "wbbbbb": 9.0},
    })
    # means: lwwwww 17/3, bbbbbb = bbbbbw 5 (tie: the first port string), llllll 11/3, wwwwww 10/3, and wbbbbb
    # 8/3: its penalty on terrain 2 counts (averaged over distances only it would lead with 9)
    assert portfolio(table, 3) == ["lwwwww", "bbbbbb", "bbbbbw"]
    assert portfolio(table, 6)[-1] == "wbbbbb"
    assert top_designs(table[table.terrain_seed == 2], 3) == ["llllll", "bbbbbb", "bbbbbw"]
    with pytest.raises(InputError, match="llllll is missing on \\[3\\]"):
        portfolio(table.drop(table.index[(table.terrain_seed == 3) & (table.design == "llllll")]), 3)


def test_the_greedy_portfolio_maximises_the_pools_best_of_k_where_the_top_k_picks_near_copies():
    table = _table({  # bbbbbb and bbbbbw win together on 1 and 2; llllll alone wins 3 and 4
        1: {"bbbbbb": 9.0, "bbbbbw": 9.0, "llllll": 0.0, "wwwwww": 1.0},
        2: {"bbbbbb": 9.0, "bbbbbw": 9.0, "llllll": 0.0, "wwwwww": 1.0},
        3: {"bbbbbb": 2.0, "bbbbbw": 1.0, "llllll": 6.0, "wwwwww": 1.0},
        4: {"bbbbbb": 2.0, "bbbbbw": 1.0, "llllll": 6.0, "wwwwww": 5.0},
    })
    # means: bbbbbb 5.5, bbbbbw 5, llllll 3, wwwwww 2: the top-2 picks the two that win the same terrains
    assert portfolio(table, 2) == ["bbbbbb", "bbbbbw"]
    # best-of-2 on average: {bbbbbb, bbbbbw} 5.5, {bbbbbb, llllll} (9 + 9 + 6 + 6) / 4 = 7.5
    assert greedy_portfolio(table, 2) == ["bbbbbb", "llllll"]
    # the third pick: wwwwww adds 0 (a tie with bbbbbw at 0: the first port string), never a repeat
    assert greedy_portfolio(table, 4) == ["bbbbbb", "llllll", "bbbbbw", "wwwwww"]
    with pytest.raises(InputError, match=r"greedy portfolio: expected between 1 and the 4 designs .* found 5"):
        greedy_portfolio(table, 5)
    with pytest.raises(InputError, match="greedy portfolio: expected every design on every pool terrain, llllll"):
        greedy_portfolio(table.drop(table.index[(table.terrain_seed == 3) & (table.design == "llllll")]), 2)


def test_the_symmetric_ceiling_equals_a_brute_force_over_the_dqn_design_space():
    rng = np.random.default_rng(0)
    designs = all_designs()
    table = pd.concat([pd.DataFrame({"terrain_seed": seed, "design": designs,
                                     "fitness": rng.uniform(-1.0, 5.0, len(designs))}) for seed in (1, 2, 3)])
    groups = ModularEgganProblem.decision_groups  # DQN decides one module per group
    space = [d for d in designs if all(d[a] == d[b] for a, b in groups)]
    assert len(space) == 64
    fitness = table.set_index(["terrain_seed", "design"]).fitness
    per_terrain = [max(fitness[(seed, d)] for d in space) for seed in (1, 2, 3)]
    means = {d: np.mean([fitness[(seed, d)] for seed in (1, 2, 3)]) for d in space}
    best = max(means, key=means.get)
    ceiling = symmetric_ceiling(table)
    assert ceiling["ceiling"] == pytest.approx(np.mean(per_terrain)) and ceiling["designs"] == 64
    assert ceiling["best_design"] == best and ceiling["best_design_mean"] == pytest.approx(means[best])
    assert ceiling["ceiling"] < table.groupby("terrain_seed").fitness.max().mean()  # the space is a subset
