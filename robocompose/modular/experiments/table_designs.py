"""Designs chosen from exhaustive tables, for Table 5.1's rows that need no learning: the terrain-agnostic
`portfolio` (the k designs best on average over the training pool) and `greedy_portfolio` (the k designs whose
best-of-k is best on average: diversity-aware), each terrain's `top_designs` (the exhaustive optimum, an oracle)
and the `symmetric_ceiling` of a designer confined to left-right symmetric designs (Whitman's DQN)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from robocompose.io.errors import InputError
from robocompose.modular.robot import mirror


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
