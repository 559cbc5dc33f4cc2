"""Random sampling (thesis Table 5.1): `n` designs drawn uniformly, evaluated in one batch, the best kept."""

from __future__ import annotations

import numpy as np

from robocompose.io.errors import InputError
from robocompose.search.problem import CountingProblem, Problem, SearchResult


def run_random(problem: Problem, n: int = 10, seed: int = 0) -> SearchResult:
    if n < 1:
        raise InputError(f"random sampling: n must be >= 1, got {n}")
    counted = CountingProblem(problem)
    population = problem.sample(np.random.default_rng(seed), n)
    fitness = counted.evaluate(population)
    return counted.result(population, fitness, [counted.best_fitness])
