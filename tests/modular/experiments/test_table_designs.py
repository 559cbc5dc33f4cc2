"""Designs chosen from exhaustive tables: the portfolio is best on average (not the per-terrain optima), the greedy
portfolio's best-of-k is best on average (it covers the terrains the top-k loses), the predict rows read the
terrain's height map and answer its own best designs where the portfolio cannot, the optimum rows are a
terrain's fittest designs, the symmetric ceiling equals a brute force over DQN's space."""

import numpy as np
import pandas as pd
import pytest
import torch

from robocompose.io.errors import InputError
from robocompose.modular.experiments.table_designs import (
    PREDICT_ROWS,
    greedy_portfolio,
    pool_rows,
    portfolio,
    predict_proposers,
    predicted_designs,
    symmetric_ceiling,
    top_designs,
)
from robocompose.modular.gate import GateConfig, height_map_features
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


def _height_map(wall: float) -> np.ndarray:
    """A (50, 20) height map: flat, or a wall `wall` m tall across the course 2 m in."""
    h = np.zeros((50, 20))
    h[10:12, :] = wall
    return h


class _Terrains:
    """A problem's task encoding alone: each seed's hand-made height map (odd seeds: a wall, even: flat)."""

    def encode_task(self, seed: int) -> torch.Tensor:
        return torch.from_numpy(_height_map(0.10 + 0.01 * seed if seed % 2 else 0.0))


def _walls_pool(seeds) -> pd.DataFrame:
    """Legs win over a wall, wheels on the flat; bbbbbb (and its twin bbbbbw) is the best on average."""
    return _table({seed: {"llllll": 3.0 if seed % 2 else 0.0, "wwwwww": 0.0 if seed % 2 else 3.0,
                          "bbbbbb": 2.0, "bbbbbw": 2.0} for seed in seeds})


def test_the_predict_rows_answer_the_held_out_terrains_own_best_design_from_its_height_map():
    pool = _walls_pool(range(1, 7))
    assert portfolio(pool, 1) == ["bbbbbb"]  # the terrain-agnostic answer: never a terrain's best
    proposers = predict_proposers(_Terrains(), pool)
    assert list(proposers) == list(PREDICT_ROWS) == ["predict_knn", "predict_ridge"]
    for name, propose in proposers.items():
        # held-out terrains 7 (a wall) and 8 (flat): each one's own best first, then the average best (ties: the
        # first port string), the other terrain's best last; the query seed changes nothing
        assert propose(_Terrains(), 7, 0, 4) == ["llllll", "bbbbbb", "bbbbbw", "wwwwww"], name
        assert propose(_Terrains(), 8, 5, 1) == propose(_Terrains(), 8, 6, 1) == ["wwwwww"], name
    with pytest.raises(InputError, match=r"protocol.candidates: expected between 1 and the 4 designs .* found 5"):
        proposers["predict_knn"](_Terrains(), 7, 0, 5)


def test_predicted_designs_reads_hand_made_features_and_only_designs_on_every_terrain():
    pool = _walls_pool([1, 2, 3, 4])
    pool.loc[(pool.terrain_seed == 4) & (pool.design == "wwwwww"), "fitness"] = np.nan  # not measured there
    rows = pool_rows(pool.dropna())
    assert list(rows.columns) == ["bbbbbb", "bbbbbw", "llllll"] and list(rows.index) == [1, 2, 3, 4]
    features = pd.DataFrame([height_map_features(_height_map(0.15 if s % 2 else 0.0)) for s in rows.index],
                            index=rows.index)
    query = pd.Series(height_map_features(_height_map(0.2)))
    assert predicted_designs(rows, features, query, 1, "knn", GateConfig(neighbours=2)) == ["llllll"]
    assert predicted_designs(rows, features, query, 2, "ridge") == ["llllll", "bbbbbb"]
    flat = pd.Series(height_map_features(_height_map(0.0)))
    assert predicted_designs(rows, features, flat, 1, "knn", GateConfig(neighbours=2)) == ["bbbbbb"]
