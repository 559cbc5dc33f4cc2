"""NSGA-II (Deb et al. 2002; thesis Algorithm 3) with pymoo, on any problem whose genomes are real vectors in
bounds and whose objectives are minimised: a `GenomeProblem` (its `objectives(X)`) and a pymoo `Sampling` of
its first population. The team-formation problem binds itself in `robocompose.teams.nsga2`.

Operators as in the thesis: single-point arithmetic crossover applied with probability `crossover_probability`
(a cut point c is drawn; genes from c on become the blends a p1 + (1 - a) p2 and (1 - a) p1 + a p2 with
a ~ U(0, 1), genes before c are copied) and uniform mutation (each gene is redrawn uniformly in its bounds with
probability `mutation_rate`); pymoo's NSGA-II survival (non-dominated sorting, crowding distance, elitist
truncation of parents + children) and, as in Algorithm 3, roulette-wheel selection of the parents: the
population is ordered by NSGA-II's crowded comparison (Pareto rank, then larger crowding distance first) and
the individual at position j of n gets a slice of the wheel proportional to n - j (linear rank weights, as the
group's public GA; a multi-objective population has no scalar fitness to make slices of, rank is what
Algorithm 3 assigns).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pymoo.algorithms.moo.nsga2 import NSGA2
from pymoo.core.crossover import Crossover
from pymoo.core.mutation import Mutation
from pymoo.core.population import Population
from pymoo.core.problem import Problem
from pymoo.core.sampling import Sampling
from pymoo.core.selection import Selection
from pymoo.core.termination import Termination
from pymoo.indicators.hv import HV
from pymoo.operators.survival.rank_and_crowding import RankAndCrowding
from pymoo.optimize import minimize
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

from robocompose.io.errors import check_field


@dataclass(frozen=True)
class NSGA2Config:
    population: int = 50  # individuals per generation (thesis: 20 and 50)
    generations: int = 50  # generations (thesis: 50)
    crossover_probability: float = 0.5  # share of matings that cross over
    mutation_rate: float = 0.1  # per-gene probability of a uniform redraw
    seed: int = 0  # seeds pymoo's Generator

    def __post_init__(self) -> None:
        check_field(self.population >= 2, "population", "an integer >= 2", self.population)
        check_field(self.generations >= 1, "generations", "an integer >= 1", self.generations)
        for name in ("crossover_probability", "mutation_rate"):
            check_field(0 <= getattr(self, name) <= 1, name, "a probability in [0, 1]", getattr(self, name))
        check_field(self.seed >= 0, "seed", "an integer >= 0", self.seed)


class GenomeProblem(Problem):
    """A pymoo problem on genomes of `n_var` genes in [xl, xu] with `n_obj` minimised objectives."""

    def objectives(self, X: np.ndarray) -> np.ndarray:
        """(B, n_obj) objectives of (B, n_var) genomes."""
        raise NotImplementedError

    def _evaluate(self, X, out, *args, **kwargs):
        out["F"] = self.objectives(X)


class RankRouletteSelection(Selection):
    """Roulette wheel over the crowded-comparison order (Algorithm 3): slice of position j of n = n - j."""

    def _do(self, problem, pop, n_select, n_parents, *args, random_state=None, **kwargs):
        rank, crowding = pop.get("rank"), pop.get("crowding")  # set by the rank-and-crowding survival
        order = np.lexsort((-crowding, rank))  # best first
        slices = np.empty(len(pop))
        slices[order] = np.arange(len(pop), 0, -1, dtype=np.float64)  # (n,) n for the best .. 1
        picks = random_state.choice(len(pop), size=n_select * n_parents, p=slices / slices.sum())
        return picks.reshape(n_select, n_parents)


class SinglePointArithmeticCrossover(Crossover):
    def __init__(self, prob: float):
        super().__init__(n_parents=2, n_offsprings=2, prob=prob)

    def _do(self, problem, X, *args, random_state=None, **kwargs):  # X: (2, n_matings, n_var)
        _, n_matings, n_var = X.shape
        cut = random_state.integers(0, n_var, size=n_matings)  # (n_matings,)
        blend = random_state.random(n_matings)[:, None]  # (n_matings, 1)
        tail = np.arange(n_var)[None, :] >= cut[:, None]  # (n_matings, n_var)
        first, second = X
        return np.stack([np.where(tail, blend * first + (1 - blend) * second, first),
                         np.where(tail, (1 - blend) * first + blend * second, second)])


class UniformMutation(Mutation):
    def __init__(self, rate: float):
        super().__init__(prob=1.0)
        self.rate = rate

    def _do(self, problem, X, *args, random_state=None, **kwargs):  # X: (n, n_var)
        redraw = random_state.random(X.shape) < self.rate
        fresh = problem.xl + random_state.random(X.shape) * (problem.xu - problem.xl)
        return np.where(redraw, fresh, X)


def non_dominated(objectives: np.ndarray) -> np.ndarray:
    """Indices of the mutually non-dominated rows of (n, M) minimised objectives (first of duplicates)."""
    _, first = np.unique(objectives, axis=0, return_index=True)
    first = np.sort(first)
    front = NonDominatedSorting().do(objectives[first], only_non_dominated_front=True)
    return first[np.sort(front)]


def hypervolume(front: np.ndarray, reference: tuple[float, ...]) -> float:
    """Volume dominated by (n, M) minimised objectives inside the box up to `reference`."""
    inside = front[(front < np.asarray(reference)).all(1)]
    return float(HV(ref_point=np.asarray(reference))(inside)) if len(inside) else 0.0


@dataclass
class Front:
    """What a run of NSGA-II found: its last population's non-dominated genomes, by their last objective."""

    genomes: np.ndarray  # (F, n_var)
    objectives: np.ndarray  # (F, n_obj), mutually non-dominated
    seconds: float  # wall time of the search
    evaluations: int  # objective evaluations requested by NSGA-II (cached or not)


class GenerationsOrStop(Termination):
    """At most `generations` generations, fewer once `stop()` says so (checked after every generation)."""

    def __init__(self, generations: int, stop: Callable[[], bool] | None):
        super().__init__()
        self.generations, self.stop = generations, stop

    def _update(self, algorithm) -> float:
        if self.stop is not None and algorithm.n_gen is not None and self.stop():
            return 1.0
        return (algorithm.n_gen or 0) / self.generations


def _algorithm(config: NSGA2Config, sampling: Sampling) -> NSGA2:
    return NSGA2(pop_size=config.population, sampling=sampling, selection=RankRouletteSelection(),
                 crossover=SinglePointArithmeticCrossover(config.crossover_probability),
                 mutation=UniformMutation(config.mutation_rate), eliminate_duplicates=True)


def _front(population: Population, seconds: float, evaluations: int) -> Front:
    genomes, objectives = population.get("X"), population.get("F")
    keep = non_dominated(objectives)
    keep = keep[np.argsort(objectives[keep, -1], kind="stable")]
    return Front(genomes[keep], objectives[keep], seconds, evaluations)


def run_nsga2(problem: GenomeProblem, sampling: Sampling, config: NSGA2Config,
              stop: Callable[[], bool] | None = None) -> Front:
    """`config.generations` generations of NSGA-II on `problem` from a first population drawn by `sampling`, or
    fewer: the run ends after the first generation at which `stop()` is true (a spend budget)."""
    started = time.perf_counter()
    result = minimize(problem, _algorithm(config, sampling), GenerationsOrStop(config.generations, stop),
                      seed=config.seed, verbose=False)
    return _front(result.pop, time.perf_counter() - started, int(result.algorithm.evaluator.n_eval))


def run_nsga2_together(runs: list[tuple[GenomeProblem, NSGA2Config]], sampling: Sampling,
                       prefetch: Callable[[list[tuple[GenomeProblem, np.ndarray]]], None]
                       ) -> tuple[list[Front], float]:
    """Several NSGA-II runs stepped together, generation by generation: every run still going asks for its
    offspring, `prefetch` sees all their genomes at once ((problem, (B, n_var) genomes) per asking run, so that
    what the runs share, like a memo of costly parts, is computed in one batch), then each run evaluates and tells.

    Each run draws exactly what it draws alone (its own seeded Generator, pymoo's ask-and-tell is its own loop);
    it can differ from its lone self only where an objective computed in a shared batch rounds differently.
    Returns the runs' fronts (`seconds`: the wall time of all of them) and that wall time."""
    started = time.perf_counter()
    algorithms = []
    for problem, config in runs:
        algorithm = _algorithm(config, sampling)
        algorithm.setup(problem, termination=GenerationsOrStop(config.generations, None), seed=config.seed,
                        verbose=False)
        algorithms.append(algorithm)
    while going := [algorithm for algorithm in algorithms if algorithm.has_next()]:
        offspring = [algorithm.ask() for algorithm in going]
        prefetch([(algorithm.problem, population.get("X")) for algorithm, population in zip(going, offspring,
                                                                                             strict=True)])
        for algorithm, population in zip(going, offspring, strict=True):
            algorithm.evaluator.eval(algorithm.problem, population, algorithm=algorithm)
            algorithm.tell(infills=population)
    seconds = time.perf_counter() - started
    return [_front(algorithm.result().pop, seconds, int(algorithm.evaluator.n_eval)) for algorithm in algorithms], \
        seconds


def survivors(genomes: np.ndarray, objectives: np.ndarray, problem: GenomeProblem, n: int,
              rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """NSGA-II's elitist survival: the `n` of (B, n_var) genomes with (B, M) objectives kept by rank, then
    crowding distance."""
    kept = RankAndCrowding().do(problem, Population.new(X=genomes, F=objectives), n_survive=n, random_state=rng)
    return kept.get("X"), kept.get("F")


def nsga2_generation(genomes: np.ndarray, objectives: np.ndarray, problem: GenomeProblem,
                     crossover_probability: float, mutation_rate: float, rng: np.random.Generator
                     ) -> tuple[np.ndarray, np.ndarray]:
    """One NSGA-II generation on a given population (Algorithm 3's loop body, EG-GAN's data creation).

    (B, n_var) genomes with (B, M) objectives: rank and crowding distance, roulette-wheel selection of
    B/2 parent pairs, single-point arithmetic crossover with probability `crossover_probability` (else
    the parents are copied), uniform mutation, evaluation of the B children by `problem`, and the
    elitist survival of B of the 2B parents and children. Returns the survivors' genomes and objectives.
    """
    survival = RankAndCrowding()
    population = survival.do(problem, Population.new(X=genomes, F=objectives), n_survive=len(genomes),
                             random_state=rng)  # sets rank and crowding
    parents = RankRouletteSelection()._do(problem, population, len(genomes) // 2, 2, random_state=rng)
    pairs = population.get("X")[parents.T]  # (2, B/2, n_var)
    crossed = SinglePointArithmeticCrossover(crossover_probability)._do(problem, pairs, random_state=rng)
    keep = rng.random(pairs.shape[1]) >= crossover_probability  # (B/2,) matings that copy their parents
    children = np.where(keep[None, :, None], pairs, crossed).reshape(-1, pairs.shape[-1])  # (B, n_var)
    children = UniformMutation(mutation_rate)._do(problem, children, random_state=rng)
    child_objectives = problem.objectives(children)
    merged = Population.new(X=np.concatenate([population.get("X"), children]),
                            F=np.concatenate([population.get("F"), child_objectives]))
    survivors = survival.do(problem, merged, n_survive=len(genomes), random_state=rng)
    return survivors.get("X"), survivors.get("F")
