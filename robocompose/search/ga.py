"""Classical genetic algorithm (GA-20 / GA-50 of thesis Table 5.2; Holland / Goldberg): tournament selection,
uniform crossover, uniform mutation, elitism.

Generation 0 is `population` random designs. Every later generation: keep the `elite` fittest unchanged; fill the
rest with children: pick two parents by binary tournament, recombine them by uniform crossover with probability
`crossover_rate` (else copy), mutate each child (each gene redrawn with probability `mutation_rate`). Every
generation is evaluated in one batch: `generations` x `population` evaluations in all.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from robocompose.io.errors import InputError
from robocompose.search.evolve import evolve
from robocompose.search.problem import Problem, SearchResult


@dataclass(frozen=True)
class GAConfig:
    population: int = 20  # thesis: 20 (GA-20) or 50 (GA-50)
    generations: int = 50  # evaluated generations, the random first one included
    crossover_rate: float = 0.9  # probability that two parents are recombined
    mutation_rate: float = 1 / 6  # per-gene redraw probability
    elite: int = 1  # fittest designs copied unchanged into the next generation
    seed: int = 0

    def __post_init__(self):
        if self.population < 2 or self.generations < 1 or not 0 <= self.elite < self.population:
            raise InputError(f"GAConfig: need population >= 2, generations >= 1, 0 <= elite < population; got {self}")


def tournament(fitness: np.ndarray, rng: np.random.Generator) -> int:
    """Index of the fitter of two uniformly drawn members (the first drawn on a tie)."""
    i, j = rng.integers(len(fitness), size=2)
    return int(i if fitness[i] >= fitness[j] else j)


def ga_generation(problem: Problem, population: list, fitness: np.ndarray, rng: np.random.Generator,
                  config: GAConfig) -> tuple[list, np.ndarray]:
    """One GA generation (the elite, then bred children); returns the new population and its (P,) fitness."""
    order = np.argsort(-fitness, kind="stable")
    children = [population[k] for k in order[:config.elite]]
    while len(children) < config.population:
        a, b = population[tournament(fitness, rng)], population[tournament(fitness, rng)]
        if rng.random() < config.crossover_rate:
            a, b = problem.crossover(a, b, rng)
        children += [problem.mutate(a, rng, config.mutation_rate), problem.mutate(b, rng, config.mutation_rate)]
    children = children[:config.population]
    return children, np.asarray(problem.evaluate(children), dtype=np.float64)


def run_ga(problem: Problem, config: GAConfig) -> SearchResult:
    return evolve(problem, partial(ga_generation, config=config), config.population, config.generations, config.seed)
