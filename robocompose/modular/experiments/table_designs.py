"""Designs chosen from exhaustive tables, for Table 5.1's rows that need no learning: the terrain-agnostic
`portfolio` (best on average over the training pool), each terrain's `top_designs` (the exhaustive optimum, an
oracle) and the `symmetric_ceiling` of a designer confined to left-right symmetric designs (Whitman's DQN)."""

from __future__ import annotations

import pandas as pd

from robocompose.io.errors import InputError
from robocompose.modular.robot import mirror


def _ranked(fitness: pd.Series, k: int) -> list[str]:
    """The `k` designs (the index) of highest fitness, ties broken by the first port string."""
    order = pd.DataFrame({"design": fitness.index, "fitness": fitness.to_numpy()})
    return list(order.sort_values(["fitness", "design"], ascending=[False, True]).design.head(k))


def portfolio(tables: pd.DataFrame, k: int) -> list[str]:
    """The `k` designs of highest mean fitness over the terrains of `tables` (penalties included), ties broken by
    the first port string: one terrain-agnostic answer for every terrain. Every design must be on every terrain."""
    fitness = tables.pivot(index="design", columns="terrain_seed", values="fitness")
    if fitness.isna().any(axis=None):
        design = fitness.index[fitness.isna().any(axis=1)][0]
        raise InputError(f"portfolio: expected every design on every pool terrain, {design} is missing on "
                         f"{[int(s) for s in fitness.columns[fitness.loc[design].isna()]]}")
    return _ranked(fitness.mean(axis=1), k)


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
