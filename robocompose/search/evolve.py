"""The generational loop the evolutionary algorithms share: a random first population, then one generation step
repeated, every population evaluated in one batch through a `CountingProblem`."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robocompose.search.problem import CountingProblem, Design, Problem, SearchResult

# (problem, population, (P,) fitness, rng) -> the next population and its (P,) fitness
Generation = Callable[[Problem, list[Design], np.ndarray, np.random.Generator], tuple[list[Design], np.ndarray]]


def evolve(problem: Problem, generation: Generation, population: int, generations: int, seed: int) -> SearchResult:
    """Sample `population` designs, then run `generation` `generations` - 1 times; `generations` evaluated in all.

    `generation` gets the counting wrapper of `problem`, so what it evaluates is counted and can become the best.
    """
    rng = np.random.default_rng(seed)
    counted = CountingProblem(problem)
    designs = problem.sample(rng, population)
    fitness = counted.evaluate(designs)
    history = [counted.best_fitness]
    for _ in range(generations - 1):
        designs, fitness = generation(counted, designs, fitness, rng)
        history.append(counted.best_fitness)
    return counted.result(designs, fitness, history)
