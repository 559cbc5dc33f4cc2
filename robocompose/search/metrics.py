"""Solution-set metrics shared by every search method."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np


def distinct_solutions(designs: Sequence, fitness: np.ndarray, distance: Callable, delta: float = 1.0,
                       epsilon: float = 0.5) -> int:
    """Number of distinct solutions (Li et al.'s niching metric, thesis 5.1, delta = 1 Hamming, epsilon = 0.5).

    Sort by fitness (best first); greedily keep each solution at distance >= delta from every kept one; count
    the kept solutions whose fitness is within epsilon of the best.
    """
    if len(designs) == 0:
        return 0
    fitness = np.asarray(fitness, dtype=np.float64)
    order = np.argsort(-fitness, kind="stable")
    best = fitness[order[0]]
    kept: list[int] = []
    for k in order:
        if all(distance(designs[k], designs[m]) >= delta for m in kept):
            kept.append(int(k))
    return sum(1 for k in kept if fitness[k] >= best - epsilon)
