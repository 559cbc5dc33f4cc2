"""Deterministic crowding GA (Mahfoud 1995; thesis Alg. 2, GA-crowding of Table 5.2): niching by pairwise
replacement, so several good, different designs survive side by side.

Every generation: pair the population at random; each pair makes two children by uniform crossover (with
probability `crossover_rate`, else copies) and mutation; the children are evaluated in one batch. Each child is
matched to the parent it is closer to (the pairing with the smaller total parent-child distance; ties keep
the straight pairing) and replaces it only if strictly fitter. `generations` x `population` evaluations in all
(generation 0 is the random population).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from robocompose.io.errors import InputError
from robocompose.search.evolve import evolve
from robocompose.search.problem import Problem, SearchResult


@dataclass(frozen=True)
class CrowdingConfig:
    population: int = 50  # thesis: 50; must be even (parents are paired)
    generations: int = 50
    crossover_rate: float = 0.9
    mutation_rate: float = 1 / 6
    seed: int = 0

    def __post_init__(self):
        if self.population < 2 or self.population % 2 or self.generations < 1:
            raise InputError(f"CrowdingConfig: need an even population >= 2 and generations >= 1; got {self}")


def crowding_generation(problem: Problem, population: list, fitness: np.ndarray, rng: np.random.Generator,
                        config: CrowdingConfig) -> tuple[list, np.ndarray]:
    """One generation of deterministic crowding; returns the new population and its (P,) fitness.

    EG-GAN runs one such generation per GAN iteration on the designs it holds.
    """
    order = rng.permutation(len(population))
    pairs = order.reshape(-1, 2)  # (P/2, 2) parent indices
    children = []
    for i, j in pairs:
        a, b = population[i], population[j]
        if rng.random() < config.crossover_rate:
            a, b = problem.crossover(a, b, rng)
        children += [problem.mutate(a, rng, config.mutation_rate), problem.mutate(b, rng, config.mutation_rate)]
    child_fitness = np.asarray(problem.evaluate(children), dtype=np.float64)
    population, fitness = list(population), fitness.copy()
    for k, (i, j) in enumerate(pairs):
        c1, c2, f1, f2 = children[2 * k], children[2 * k + 1], child_fitness[2 * k], child_fitness[2 * k + 1]
        p1, p2 = population[i], population[j]
        straight = problem.distance(p1, c1) + problem.distance(p2, c2)
        crossed = problem.distance(p1, c2) + problem.distance(p2, c1)
        matches = [(i, c1, f1), (j, c2, f2)] if straight <= crossed else [(i, c2, f2), (j, c1, f1)]
        for parent, child, child_fit in matches:
            if child_fit > fitness[parent]:
                population[parent], fitness[parent] = child, child_fit
    return population, fitness


def run_crowding(problem: Problem, config: CrowdingConfig) -> SearchResult:
    return evolve(problem, partial(crowding_generation, config=config), config.population, config.generations,
                  config.seed)
