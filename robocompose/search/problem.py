"""The problem interface the evolutionary algorithms work on, and what a search returns.

A problem owns its design representation (any object; the algorithms only pass designs back to it) and its
fitness, which is maximised. `evaluate` takes a batch so that a problem can fan evaluations out or read them
from a cache; the algorithms count what they ask for.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

Design = Any


class Problem(Protocol):
    def sample(self, rng: np.random.Generator, n: int) -> list[Design]:
        """`n` designs drawn uniformly from the design space."""
        ...

    def mutate(self, design: Design, rng: np.random.Generator, rate: float) -> Design:
        """A copy of `design` with each gene redrawn uniformly with probability `rate`."""
        ...

    def crossover(self, a: Design, b: Design, rng: np.random.Generator) -> tuple[Design, Design]:
        """Two children of uniform crossover: each gene from either parent with probability 1/2, complementarily."""
        ...

    def distance(self, a: Design, b: Design) -> float:
        """Distance between two designs (the niching metric and crowding's parent-child matching use it)."""
        ...

    def evaluate(self, designs: Sequence[Design]) -> np.ndarray:
        """(B,) fitness of each design (higher is better)."""
        ...


@dataclass
class SearchResult:
    """The final population of a search with its fitness, the best design seen, and the cost."""

    population: list[Design]
    fitness: np.ndarray  # (P,)
    best: Design
    best_fitness: float
    evaluations: int  # designs handed to problem.evaluate (repeats included)
    best_per_generation: list[float] = field(default_factory=list)


class CountingProblem:
    """A problem that counts its evaluations and tracks the best design ever evaluated (first found wins ties)."""

    def __init__(self, problem: Problem):
        self.problem = problem
        self.evaluations = 0
        self.best: Design = None
        self.best_fitness = -np.inf
        self.sample, self.mutate = problem.sample, problem.mutate
        self.crossover, self.distance = problem.crossover, problem.distance

    def evaluate(self, designs: Sequence[Design]) -> np.ndarray:
        fitness = np.asarray(self.problem.evaluate(designs), dtype=np.float64)
        self.evaluations += len(designs)
        if len(fitness) and fitness.max() > self.best_fitness:
            k = int(np.argmax(fitness))
            self.best, self.best_fitness = designs[k], float(fitness[k])
        return fitness

    def result(self, population: list[Design], fitness: np.ndarray, history: list[float]) -> SearchResult:
        return SearchResult(population, fitness, self.best, self.best_fitness, self.evaluations, history)
