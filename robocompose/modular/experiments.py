"""The modular-robot experiments: exhaustive ground truth, evolutionary baselines, emergency constraints.

- `exhaustive_table`: every one of the 4096 designs on every test terrain, under the fitness rule (designs the
  rule skips are scored without simulating). The thesis never had this; it gives each method's regret.
- `run_method`: GA-20, GA-50, GA-crowding or random sampling on one terrain with one seed.
- `baseline_runs`: all methods x test terrains x seeds, with distinct solutions, emergency-constraint scores and
  the exhaustive optimum beside each.

Emergency constraints (thesis 5.1): a draw caps the count of one module type (leg, wheel or leg-wheel, uniform)
at 0, 1 or 2 (uniform), i.e. a shortage of that module. A method answers with its best output design (final
population; random sampling: its samples) that satisfies the cap; if none does, with a uniformly drawn feasible
design (satisfies the cap, and is not one the fitness rule rejects unsimulated). The exhaustive optimum under
the same draw is the best satisfying design of the table.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from robocompose.evaluation.cache import EvaluationCache
from robocompose.evaluation.executor import Executor
from robocompose.io.errors import InputError
from robocompose.modular.evaluate import evaluate_designs
from robocompose.modular.params import ModularParams
from robocompose.modular.problem import ModularProblem
from robocompose.modular.robot import all_designs
from robocompose.search.crowding import CrowdingConfig, run_crowding
from robocompose.search.ga import GAConfig, run_ga
from robocompose.search.metrics import distinct_solutions
from robocompose.search.problem import SearchResult
from robocompose.search.random_search import run_random

METHODS = {"ga20": "GA-20", "ga50": "GA-50", "crowding": "GA-crowding", "random": "Random sampling"}
EC_MODULES = "lwb"  # module types an emergency constraint can cap
EC_CAPS = (0, 1, 2)
DELTA, EPSILON = 1.0, 0.5  # the niching metric's Hamming distance and fitness margin (thesis)


def exhaustive_table(params: ModularParams, cache: EvaluationCache | None, executor: Executor | None,
                     save_every: int = 32, designs: list[str] | None = None) -> pd.DataFrame:
    """(terrains x 4096) rows: terrain_seed, design, fitness, distance, status, sim_steps; sorted.

    `designs` restricts the table to a subset (tests); None is all 4096.
    """
    designs = all_designs() if designs is None else designs
    frames = []
    for terrain_seed in params.experiments.test_terrains:
        results = evaluate_designs(designs, terrain_seed, params.eval, params.fitness, cache, executor, save_every)
        frames.append(pd.DataFrame({
            "terrain_seed": terrain_seed, "design": designs,
            "fitness": [params.fitness.fitness(r) for r in results],
            "distance": [r.distance for r in results], "status": [r.status for r in results],
            "sim_steps": [r.sim_steps for r in results]}))
    return pd.concat(frames, ignore_index=True).sort_values(["terrain_seed", "design"], ignore_index=True)


def truth_summary(table: pd.DataFrame, epsilon: float = EPSILON) -> pd.DataFrame:
    """Per terrain: the optimum, its design(s), the near-optimal designs (within epsilon) and how many there are."""
    rows = []
    for terrain_seed, group in table.groupby("terrain_seed", sort=True):
        best = group.fitness.max()
        near = group[group.fitness >= best - epsilon].sort_values(["fitness", "design"], ascending=[False, True])
        rows.append({"terrain_seed": int(terrain_seed), "optimum": float(best),
                     "best_design": near.design.iloc[0], "near_optimal": len(near),
                     "near_optimal_designs": " ".join(near.design.head(8)),
                     "simulated": int((group.sim_steps > 0).sum())})
    return pd.DataFrame(rows)


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
    def best_distance(self) -> float:
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
               cache: EvaluationCache | None = None, executor: Executor | None = None) -> MethodRun:
    """One run of `variant` on terrain `terrain_seed` (run seed `seed`), with its distinct-solution count."""
    import time

    if variant not in METHODS:
        raise InputError(f"method {variant!r}: expected one of {sorted(METHODS)}")
    problem = ModularProblem(terrain_seed, params.eval, params.fitness, cache, executor)
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
               rng: np.random.Generator, feasible: Callable[[str], bool] = lambda design: True) -> list[str]:
    """The design a method answers each constraint with: its best satisfying output, else a random feasible one
    (satisfying the constraint and `feasible`)."""
    order = np.argsort(-np.asarray(fitness), kind="stable")
    answers = []
    for constraint in constraints:
        ok = [designs[k] for k in order if satisfies(designs[k], constraint)]
        if ok:
            answers.append(ok[0])
            continue
        while True:  # rejection sampling: every cap admits hundreds of feasible designs, so this ends fast
            design = "".join("nlwb"[int(i)] for i in rng.integers(4, size=6))
            if satisfies(design, constraint) and feasible(design):
                answers.append(design)
                break
    return answers


def baseline_runs(params: ModularParams, truth: pd.DataFrame, cache: EvaluationCache | None,
                  executor: Executor | None) -> pd.DataFrame:
    """Every method x test terrain x seed (declared table `modular_runs`)."""
    e = params.experiments
    rows = []
    for terrain_seed in e.test_terrains:
        table = truth[truth.terrain_seed == terrain_seed]
        if len(table) == 0:
            raise InputError(f"terrain {terrain_seed}: not in the exhaustive table (run modular_exhaustive first)")
        fitness_of = dict(zip(table.design, table.fitness, strict=True))
        for variant in METHODS:
            for seed in e.ga_seeds:
                run = run_method(variant, terrain_seed, seed, params, cache, executor)
                rng = np.random.default_rng(_seed(seed, terrain_seed, 7919))  # the same draws for every method
                constraints = emergency_constraints(rng, e.ec_draws)
                answers = ec_answers(run.result.population, run.result.fitness, constraints, rng,
                                     feasible=lambda design: not params.fitness.skips(design))
                problem = ModularProblem(terrain_seed, params.eval, params.fitness, cache, executor)
                ec_fitness = problem.evaluate(answers)
                ec_optimum = [max(f for d, f in fitness_of.items() if satisfies(d, c)) for c in constraints]
                rows.append({"method": variant, "terrain_seed": terrain_seed, "seed": seed,
                             "best_design": run.best_design, "best_fitness": run.best_distance,
                             "distinct": run.distinct, "ec_fitness": float(np.mean(ec_fitness)),
                             "ec_optimum": float(np.mean(ec_optimum)), "optimum": float(table.fitness.max()),
                             "evaluations": run.evaluations, "sim_steps": run.sim_steps})
    return pd.DataFrame(rows)
