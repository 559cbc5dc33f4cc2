"""Designs chosen from exhaustive tables, for Table 5.1's rows that need no learning: the terrain-agnostic
`portfolio` (the k designs best on average over the training pool) and `greedy_portfolio` (the k designs whose
best-of-k is best on average: diversity-aware), the terrain-reading `predicted_designs` (the k designs best in the
terrain's row of the table as predicted from its height map and the pool's, `predict_proposers`: the gate's
predictability ceiling, `robocompose.modular.gate`), each terrain's `top_designs` (the exhaustive optimum, an
oracle) and the `symmetric_ceiling` of a designer confined to left-right symmetric designs (Whitman's DQN)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd

from robocompose.io.errors import InputError
from robocompose.modular.gate import GateConfig, height_map_features, predict_row
from robocompose.modular.robot import mirror

# Table 5.1's predict rows -> the gate's predictor that answers them
PREDICT_ROWS = {"predict_knn": "knn", "predict_ridge": "ridge"}


def _ranked(fitness: pd.Series, k: int) -> list[str]:
    """The `k` designs (the index) of highest fitness, ties broken by the first port string."""
    order = pd.DataFrame({"design": fitness.index, "fitness": fitness.to_numpy()})
    return list(order.sort_values(["fitness", "design"], ascending=[False, True]).design.head(k))


def _pool_fitness(tables: pd.DataFrame, what: str) -> pd.DataFrame:
    """design x terrain fitness of `tables`, designs sorted by port string; InputError naming `what` if a design
    is missing on a terrain."""
    fitness = tables.pivot(index="design", columns="terrain_seed", values="fitness").sort_index()
    if fitness.isna().any(axis=None):
        design = fitness.index[fitness.isna().any(axis=1)][0]
        raise InputError(f"{what}: expected every design on every pool terrain, {design} is missing on "
                         f"{[int(s) for s in fitness.columns[fitness.loc[design].isna()]]}")
    return fitness


def portfolio(tables: pd.DataFrame, k: int) -> list[str]:
    """The `k` designs of highest mean fitness over the terrains of `tables` (penalties included), ties broken by
    the first port string: one terrain-agnostic answer for every terrain. Every design must be on every terrain."""
    return _ranked(_pool_fitness(tables, "portfolio").mean(axis=1), k)


def greedy_portfolio(tables: pd.DataFrame, k: int) -> list[str]:
    """The diversity-aware portfolio: `k` designs picked one at a time, each the design that most raises the mean
    over the terrains of `tables` of the best fitness among those picked (its first pick is the portfolio's first;
    ties: the first port string), in pick order. The top-k `portfolio` may pick k near-copies that win on the
    same terrains; this one covers the terrains the first picks lose. Every design must be on every terrain."""
    fitness = _pool_fitness(tables, "greedy portfolio")
    values, designs = fitness.to_numpy(), list(fitness.index)
    if not 1 <= k <= len(designs):
        raise InputError(f"greedy portfolio: expected between 1 and the {len(designs)} designs of the pool, found {k}")
    best, picked = np.full(values.shape[1], -np.inf), []
    for _ in range(k):
        gain = np.maximum(values, best).mean(axis=1)
        gain[picked] = -np.inf  # a design picked twice adds nothing: the next best new one instead
        pick = int(np.argmax(gain))  # the first maximum: designs are sorted by port string
        picked.append(pick)
        best = np.maximum(best, values[pick])
    return [designs[i] for i in picked]


def pool_rows(tables: pd.DataFrame) -> pd.DataFrame:
    """terrain x design fitness of `tables` (penalties included), rows sorted by seed, columns by port string: the
    designs every terrain of `tables` has a fitness for (InputError if none)."""
    rows = tables.pivot(index="terrain_seed", columns="design", values="fitness").sort_index()
    rows = rows.sort_index(axis=1).dropna(axis=1)
    if rows.shape[1] == 0:
        raise InputError(f"predict the table: expected designs with a fitness on every pool terrain "
                         f"{[int(s) for s in rows.index]}, found none")
    return rows


def predicted_designs(rows: pd.DataFrame, features: pd.DataFrame, query: pd.Series, k: int, predictor: str,
                      config: GateConfig | None = None) -> list[str]:
    """The `k` designs best in a terrain's row of the table as `predictor` (`robocompose.modular.gate.PREDICTORS`)
    predicts it from the terrain's `query` features, the training terrains' `features` (rows: the terrains of
    `rows`; columns: those of `query`) and their `rows` of the table (`pool_rows`); ties: the first port string.
    `config`: the predictors' settings (None: the gate's defaults, 3 neighbours and ridge penalty 1)."""
    if not features.index.equals(rows.index):
        raise ValueError(f"features: expected the rows' terrains {list(rows.index)}, found {list(features.index)}")
    if not 1 <= k <= rows.shape[1]:
        raise InputError(f"eggan_modular.protocol.candidates: expected between 1 and the {rows.shape[1]} designs "
                         f"of the pool's table, found {k}")
    row = predict_row(features.to_numpy(dtype=np.float64), rows.to_numpy(dtype=np.float64),
                      query[features.columns].to_numpy(dtype=np.float64), predictor, config or GateConfig())
    return _ranked(pd.Series(row, index=rows.columns), k)


def terrain_features(problem, terrain_seed: int) -> pd.Series:
    """A terrain's height-map features (`gate.height_map_features`) as the learners see it: `problem.encode_task`,
    the terrain generated from its seed under the params' terrain config."""
    return pd.Series(height_map_features(problem.encode_task(int(terrain_seed)).numpy()))


def predict_proposers(problem, tables: pd.DataFrame,
                      config: GateConfig | None = None) -> dict[str, Callable[..., list[str]]]:
    """Table 5.1's predict rows (`PREDICT_ROWS`), as the protocol's proposers (problem, terrain seed, query seed,
    candidates -> designs): the test terrain's features (`terrain_features`), its row of the table predicted from
    the pool terrains of `tables` (each one's features from its own height map under `problem`; the designs every
    one has a fitness for) by k-NN (`config.neighbours`) or ridge (`config.ridge`), and the designs predicted best
    (`predicted_designs`; `config` None: the gate's defaults). Deterministic: the query seed is not used."""
    rows, config = pool_rows(tables), config or GateConfig()
    features = pd.DataFrame([terrain_features(problem, seed) for seed in rows.index], index=rows.index)

    def proposer(predictor: str):
        def propose(problem, terrain_seed: int, query_seed: int, candidates: int) -> list[str]:
            return predicted_designs(rows, features, terrain_features(problem, terrain_seed), candidates, predictor,
                                     config)
        return propose

    return {row: proposer(predictor) for row, predictor in PREDICT_ROWS.items()}


def top_designs(table: pd.DataFrame, k: int) -> list[str]:
    """One terrain's `k` fittest designs of its exhaustive table (ties: the first port string)."""
    if table.terrain_seed.nunique() != 1:
        raise ValueError(f"top designs of one terrain, found seeds {sorted(table.terrain_seed.unique())}")
    return _ranked(table.set_index("design").fitness, k)


def symmetric_ceiling(tables: pd.DataFrame) -> dict:
    """What a designer of left-right symmetric designs only (`mirror(d) == d`, as Whitman's DQN builds: one module
    per mirrored port pair) can reach on the terrains of `tables`: `ceiling`, the mean over terrains of each
    terrain's best symmetric fitness (the most its max distance can be), and the single symmetric design best on
    average (`best_design`, its `best_design_mean`)."""
    symmetric = tables[tables.design.map(lambda d: mirror(d) == d)]
    if symmetric.empty:
        raise ValueError("symmetric ceiling: the tables hold no left-right symmetric design")
    per_terrain = symmetric.groupby("terrain_seed").fitness.max()
    means = symmetric.pivot(index="design", columns="terrain_seed", values="fitness").mean(axis=1)
    best = _ranked(means, 1)[0]
    return {"terrains": len(per_terrain), "designs": len(means), "ceiling": float(per_terrain.mean()),
            "best_design": best, "best_design_mean": float(means[best])}
