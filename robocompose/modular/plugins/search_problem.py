"""The modular-robot design problem on one terrain, for the generic searches in `robocompose.search`.

Designs are port strings (6 letters of n/l/w/b); genes are ports; the distance is the Hamming distance; the
fitness is the evaluator's distance under the fitness rule (see `robocompose.modular.evaluate`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.modular.evaluate import EvalSettings, FitnessRule, Result, evaluate_designs
from robocompose.modular.robot import MODULE_LETTERS, N_PORTS, index_to_design


def hamming(a: str, b: str) -> int:
    return sum(x != y for x, y in zip(a, b, strict=True))


class ModularProblem:
    """Designs of the 6-port chassis on terrain `terrain_seed`, evaluated through the shared cache and executor,
    or read from `known` (every design's measured result on this terrain: its exhaustive table) when given."""

    def __init__(self, terrain_seed: int, settings: EvalSettings, rule: FitnessRule,
                 cache: EvaluationCache | None = None, executor: Executor | None = None,
                 known: Mapping[str, Result] | None = None):
        self.terrain_seed = terrain_seed
        self.settings = settings
        self.rule = rule
        self.cache = cache
        self.executor = executor
        self.known = known
        self.sim_steps = 0  # steps the evaluations asked for would cost without a cache (repeats included)
        self.sim_seconds = 0.0  # their measured simulation seconds (as recorded in the cache for hits)

    def sample(self, rng: np.random.Generator, n: int) -> list[str]:
        return [index_to_design(row) for row in rng.integers(len(MODULE_LETTERS), size=(n, N_PORTS))]

    def mutate(self, design: str, rng: np.random.Generator, rate: float) -> str:
        redraw = rng.random(N_PORTS) < rate
        if not redraw.any():  # the common case at rate 1/6, and no draw is skipped: integers(size=0) draws none
            return design
        genes = list(design)
        for port, module in zip(np.flatnonzero(redraw).tolist(),
                                rng.integers(len(MODULE_LETTERS), size=int(redraw.sum())).tolist(), strict=True):
            genes[port] = MODULE_LETTERS[module]
        return "".join(genes)

    def crossover(self, a: str, b: str, rng: np.random.Generator) -> tuple[str, str]:
        swap = rng.random(N_PORTS) < 0.5
        return ("".join(y if s else x for x, y, s in zip(a, b, swap, strict=True)),
                "".join(x if s else y for x, y, s in zip(a, b, swap, strict=True)))

    def distance(self, a: str, b: str) -> float:
        return float(hamming(a, b))

    def evaluate(self, designs: Sequence[str]) -> np.ndarray:
        if self.known is not None:
            results = [self.known[d] for d in designs]
        else:
            results = evaluate_designs(designs, self.terrain_seed, self.settings, self.rule, self.cache,
                                       self.executor)
        self.sim_steps += sum(r.sim_steps for r in results)
        self.sim_seconds += sum(r.seconds for r in results)
        return np.array([self.rule.fitness(r) for r in results], dtype=np.float64)
