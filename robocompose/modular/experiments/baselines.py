"""The modular-robot experiments: evolutionary baselines and emergency constraints on the test terrains.

- `run_method`: GA-20, GA-50, GA-crowding or random sampling on one terrain with one seed.
- `baseline_runs`: all methods x test terrains x seeds, with distinct solutions, emergency-constraint distances and
  the exhaustive optimum beside each. The runs read every fitness from the terrain's exhaustive table (the real
  evaluator's measured results for every design; `robocompose.modular.truth`), so their runtime is the measured
  simulation time of the evaluations they asked for, repeats included: the cost without a cache.

Emergency constraints (thesis 5.1): a draw caps the count of one module type (leg, wheel or leg-wheel, uniform)
at 0, 1 or 2 (uniform), i.e. a shortage of that module. A method answers with its best output design (final
population; random sampling: its samples) that is valid (not rejected by the fitness rule) and satisfies the
cap; if none is, with a uniformly drawn valid satisfying design. The exhaustive optimum under the same draw is the
best valid satisfying design of the table.

Penalties are never averaged as distances: a run whose best design carries no distance (every design it saw was
invalid or unstable) has no best distance and counts as a failure; an emergency answer without a distance (an
unstable rollout) counts as an EC failure, and the EC distance is the mean over the answers that have one.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.io.errors import InputError
from robocompose.modular.evaluate import Result
from robocompose.modular.params import ModularParams
from robocompose.modular.plugins.search_problem import ModularProblem
from robocompose.modular.robot import MODULE_LETTERS, N_PORTS, index_to_design
from robocompose.search.crowding import CrowdingConfig, run_crowding
from robocompose.search.ga import GAConfig, run_ga
from robocompose.search.metrics import distinct_solutions
from robocompose.search.problem import SearchResult
from robocompose.search.random_search import run_random

METHODS = {"ga20": "GA-20", "ga50": "GA-50", "crowding": "GA-crowding", "random": "Random sampling"}
EC_MODULES = "lwb"  # module types an emergency constraint can cap
EC_CAPS = (0, 1, 2)
DELTA, EPSILON = 1.0, 0.5  # the niching metric's Hamming distance and fitness margin (thesis)


def table_results(table: pd.DataFrame) -> dict[str, Result]:
    """Design -> the evaluator's result, from one terrain's exhaustive table (null distance -> None)."""
    return {d: Result(None if pd.isna(x) else float(x), st, int(n), float(sec))
            for d, x, st, n, sec in zip(table.design, table.distance, table.status, table.sim_steps, table.seconds,
                                        strict=True)}


def _seed(*parts: int) -> int:
    return int(np.random.SeedSequence(list(parts)).generate_state(1)[0])


@dataclass
class MethodRun:
    method: str
    terrain_seed: int
    seed: int
    result: SearchResult
    distinct: int
    sim_steps: int
    seconds: float  # wall time of the run (cache hits are free)
    sim_seconds: float  # stored simulation seconds of the evaluations asked for (the cost without a cache)

    @property
    def best_design(self) -> str:
        return self.result.best

    @property
    def best_fitness(self) -> float:
        return self.result.best_fitness

    @property
    def evaluations(self) -> int:
        return self.result.evaluations


def search(variant: str, problem: ModularProblem, seed: int, params: ModularParams) -> SearchResult:
    """Run one method on a problem; `seed` is the method's own seed."""
    e = params.experiments
    if variant in ("ga20", "ga50"):
        config = GAConfig(population=20 if variant == "ga20" else 50, generations=e.generations,
                          crossover_rate=e.crossover_rate, mutation_rate=e.mutation_rate, elite=e.elite, seed=seed)
        return run_ga(problem, config)
    if variant == "crowding":
        return run_crowding(problem, CrowdingConfig(population=50, generations=e.generations,
                                                    crossover_rate=e.crossover_rate, mutation_rate=e.mutation_rate,
                                                    seed=seed))
    if variant == "random":
        return run_random(problem, e.random_designs, seed)
    raise InputError(f"method {variant!r}: expected one of {sorted(METHODS)}")


def run_method(variant: str, terrain_seed: int, seed: int, params: ModularParams,
               cache: EvaluationCache | None = None, executor: Executor | None = None,
               known: Mapping[str, Result] | None = None) -> MethodRun:
    """One run of `variant` on terrain `terrain_seed` (run seed `seed`), with its distinct-solution count.

    `known`: every design's result on this terrain (its exhaustive table); None simulates through the cache.
    """
    import time

    if variant not in METHODS:
        raise InputError(f"method {variant!r}: expected one of {sorted(METHODS)}")
    problem = ModularProblem(terrain_seed, params.eval, params.fitness, cache, executor, known)
    started = time.perf_counter()
    result = search(variant, problem, _seed(seed, terrain_seed, list(METHODS).index(variant)), params)
    seconds = time.perf_counter() - started
    distinct = distinct_solutions(result.population, result.fitness, problem.distance, DELTA, EPSILON)
    return MethodRun(variant, terrain_seed, seed, result, distinct, problem.sim_steps, seconds, problem.sim_seconds)


def emergency_constraints(rng: np.random.Generator, n: int) -> list[tuple[str, int]]:
    """`n` draws of (capped module letter, cap)."""
    return [(EC_MODULES[int(rng.integers(len(EC_MODULES)))], int(EC_CAPS[int(rng.integers(len(EC_CAPS)))]))
            for _ in range(n)]


def satisfies(design: str, constraint: tuple[str, int]) -> bool:
    module, cap = constraint
    return design.count(module) <= cap


def ec_answers(designs: list[str], fitness: np.ndarray, constraints: list[tuple[str, int]],
               rng: np.random.Generator, valid: Callable[[str], bool]) -> list[str]:
    """The design a method answers each constraint with: its fittest output design that is `valid` and satisfies
    the constraint, else a uniformly drawn valid satisfying design."""
    order = np.argsort(-np.asarray(fitness), kind="stable")
    answers = []
    for constraint in constraints:
        ok = [designs[k] for k in order if satisfies(designs[k], constraint) and valid(designs[k])]
        if ok:
            answers.append(ok[0])
            continue
        while True:  # rejection sampling: every cap admits hundreds of valid designs, so this ends fast
            design = index_to_design(rng.integers(len(MODULE_LETTERS), size=N_PORTS))
            if satisfies(design, constraint) and valid(design):
                answers.append(design)
                break
    return answers


def baseline_runs(params: ModularParams, truth: pd.DataFrame) -> pd.DataFrame:
    """Every method x test terrain x seed (declared table `modular_runs`), every fitness read from `truth`."""
    e = params.experiments
    rule = params.fitness
    rows = []
    for terrain_seed in e.test_terrains:
        table = truth[truth.terrain_seed == terrain_seed]
        if len(table) == 0:
            raise InputError(f"terrain {terrain_seed}: not in the exhaustive table (run modular_exhaustive first)")
        known = table_results(table)
        distances = table.dropna(subset=["distance"])
        for variant in METHODS:
            for seed in e.ga_seeds:
                run = run_method(variant, terrain_seed, seed, params, known=known)
                rng = np.random.default_rng(_seed(seed, terrain_seed, 7919))  # the same draws for every method
                constraints = emergency_constraints(rng, e.ec_draws)
                answers = ec_answers(run.result.population, run.result.fitness, constraints, rng,
                                     valid=lambda design: not rule.skips(design))
                ec = [known[a].distance for a in answers]
                ec_measured = [x for x in ec if x is not None]
                ec_optimum = [distances.distance[distances.design.map(lambda d, c=c: satisfies(d, c))].max()
                              for c in constraints]
                rows.append({"method": variant, "terrain_seed": terrain_seed, "seed": seed,
                             "best_design": run.best_design, "best_distance": known[run.best_design].distance,
                             "distinct": run.distinct,
                             "ec_distance": float(np.mean(ec_measured)) if ec_measured else None,
                             "ec_failures": len(ec) - len(ec_measured), "ec_optimum": float(np.mean(ec_optimum)),
                             "optimum": float(distances.distance.max()), "evaluations": run.evaluations,
                             "sim_steps": run.sim_steps, "sim_seconds": run.sim_seconds})
    return pd.DataFrame(rows)
