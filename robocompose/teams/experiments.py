"""The experiments of thesis Tables 5.4 and 5.5 on the decomposed test chips.

Every row of a table runs on the same chips and seeds: Table 5.4 on the first `table_5_4_chips`
test chips, Table 5.5 on the first `table_5_5_chips`, each on every one of `seeds` (EG-GAN's rows
come from generative.py on the same chips). Table 5.4: NSGA-II with each genome and population size per chip
and seed. The runs of one chip and seed are stepped together over one team-cost memo (`_nsga2_group`): each
generation's new teams of all of them are optimised in one batch, which costs about what one run's batch costs, and
each run counts its own spend. The runtime a user waits for is timed apart: every (genome, population) run alone on
the first chip and seed with an empty memo (as the thesis times a run from scratch). Runtimes are returned apart
from the runs table, which DVC hashes (wall time is not reproducible). Table 5.5: the baselines of baselines.py at
each deployment budget, per chip and seed. Beside Table 5.4, random-allocation fronts: the non-dominated set of 64
and of 512 draws of NSGA-II's initial sampler, the count a query decodes (a learner must beat them to have learned
anything).

The runs (chip x seed x population) and the per-chip baselines are independent tasks, fanned out
through the project's Executor (local processes or a Dask cluster; None = in this process). Each task
runs with the caller's torch thread count (the stage sets `teams.threads`, 1) and results are gathered
in task order, so the tables do not depend on the backend or the number of workers.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pandas as pd
import torch

from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.search.nsga2 import NSGA2Config, non_dominated
from robocompose.teams.baselines import no_decomposition_costs, random_allocation, random_species_counts, random_teams
from robocompose.teams.chips import Chip, read_chip
from robocompose.teams.decompose import Decomposition, chip_decomposition
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.evaluator import AllocationEvaluator, chip_coverage, teams_cache
from robocompose.teams.nsga2 import (
    NSGA2Result,
    allocation_nsga2,
    allocation_nsga2_together,
    deployment_share_draws,
    team_hypervolume,
)
from robocompose.teams.params import ExperimentsConfig
from robocompose.teams.species import SPECIES, allocation_to_counts, deployment_cost


def decomposed_chips(regions: pd.DataFrame, split: str) -> list[tuple[Chip, Decomposition]]:
    """(chip, its regions) of every chip of `split` in the regions table, sorted by chip id."""
    return [(read_chip(chip_id, rows.source.iloc[0]), chip_decomposition(rows))
            for chip_id, rows in regions[regions.split == split].groupby("chip_id", sort=True)]


def _nsga2_run(task: tuple[Chip, Decomposition, CoverageConfig, NSGA2Config, str, int, int | None]
               ) -> tuple[NSGA2Result, AllocationEvaluator]:
    """One NSGA-II run on one chip (an executor task), from an empty team-cost memo: its result and evaluator.
    With a team budget, the run ends after the first generation at which it has optimised that many teams."""
    chip, decomposition, coverage, nsga2, genome, threads, max_teams = task
    torch.set_num_threads(threads)
    evaluate = AllocationEvaluator(chip_coverage(chip, decomposition, coverage), chip.chip_id, nsga2.seed)
    stop = None if max_teams is None else (lambda: len(evaluate.asked) >= max_teams)
    result = allocation_nsga2(evaluate, decomposition.n_regions, len(SPECIES), coverage.robots_per_species, nsga2,
                              genome, stop)
    return result, evaluate


def _nsga2_group(task: tuple[Chip, Decomposition, CoverageConfig, list[tuple[NSGA2Config, str]], int]
                 ) -> tuple[list[tuple[NSGA2Result, AllocationEvaluator]], float]:
    """The NSGA-II runs (settings, genome) of one chip and seed (an executor task), stepped together over one
    team-cost memo that starts empty: their results, each with its own evaluator (its spend), and their wall time."""
    chip, decomposition, coverage, settings, threads = task
    torch.set_num_threads(threads)
    (seed,) = {nsga2.seed for nsga2, _ in settings}  # the memo holds the costs of one robot-start seed
    plan, memo = chip_coverage(chip, decomposition, coverage), teams_cache()
    shared = AllocationEvaluator(plan, chip.chip_id, seed, memo)
    evaluators = [AllocationEvaluator(plan, chip.chip_id, seed, memo) for _ in settings]
    results, seconds = allocation_nsga2_together(
        [(evaluate, nsga2, genome) for evaluate, (nsga2, genome) in zip(evaluators, settings, strict=True)],
        decomposition.n_regions, len(SPECIES), coverage.robots_per_species, shared.team_costs)
    return list(zip(results, evaluators, strict=True)), seconds


def nsga2_runs(chips: list[tuple[Chip, Decomposition]], coverage: CoverageConfig, config: ExperimentsConfig,
               cache: EvaluationCache, executor: Executor | None = None
               ) -> tuple[pd.DataFrame, pd.DataFrame, dict[str, list[dict]]]:
    """Run NSGA-II per chip x seed x genome x population, the runs of a chip and seed stepped together (its
    evaluations: the allocations it scored; its team look-ups against the distinct teams it optimised: what the
    memo saved it), every team cost merged into `cache`.

    Returns the "teams_nsga2" and "teams_fronts" tables and, for the untracked timings file, the wall times:
    "nsga2_groups" (chip_id, seed, seconds of its runs together) and "nsga2_alone" (each genome and population
    run alone from an empty memo on the first chip and seed: chip_id, genome, population, seed, seconds).
    """
    def settings(seed: int) -> list[tuple[NSGA2Config, str]]:
        return [(NSGA2Config(population=population, generations=config.generations,
                             crossover_probability=config.crossover_probability, mutation_rate=config.mutation_rate,
                             seed=seed), genome)
                for genome in config.genomes for population in config.populations]

    tasks = [(chip, decomposition, coverage, settings(seed), torch.get_num_threads())
             for chip, decomposition in chips[:config.table_5_4_chips] for seed in config.seeds]
    groups = (executor or Executor(workers=1)).map(_nsga2_group, tasks)
    rows, fronts, timings = [], [], []
    for (chip, _, _, runs, _), (results, seconds) in zip(tasks, groups, strict=True):
        cache.merge(results[0][1].cache)  # the group's one memo (keys carry the chip and seed: no overlap)
        timings.append({"chip_id": chip.chip_id, "seed": runs[0][0].seed, "seconds": round(seconds, 2)})
        for (nsga2, genome), (result, evaluator) in zip(runs, results, strict=True):
            rows.append((chip.chip_id, genome, nsga2.population, nsga2.seed, nsga2.generations, result.hypervolume,
                         result.evaluations, evaluator.lookups, len(evaluator.asked)))
            fronts += [(chip.chip_id, genome, nsga2.population, nsga2.seed, cost, int(deploy),
                        counts.ravel().tolist())
                       for (cost, deploy), counts in zip(result.front, result.counts, strict=True)]
    chip, decomposition = chips[0]
    _, _, alone = budgeted_nsga2_runs([(chip, decomposition, nsga2, genome) for nsga2, genome in
                                       settings(config.seeds[0])], coverage, teams_cache(), executor)
    return (pd.DataFrame(rows, columns=NSGA2_COLUMNS), pd.DataFrame(fronts, columns=FRONT_COLUMNS),
            {"nsga2_groups": timings, "nsga2_alone": alone})


def nsga2_alone(chip: Chip, decomposition: Decomposition, coverage: CoverageConfig, config: ExperimentsConfig,
                executor: Executor | None = None) -> list[dict]:
    """Table 5.4's time to a measured front for NSGA-II, as a user waits for it: each genome x population run alone
    from an empty team-cost memo on `chip` at the first seed (chip_id, genome, population, seed, seconds). Stage
    teams_eggan times them in the same run as EG-GAN's queries, so both sides of the speed ratio see one machine
    load (teams_baselines' own record of them is as old as its committed piece)."""
    runs = [(chip, decomposition, NSGA2Config(population=population, generations=config.generations,
                                              crossover_probability=config.crossover_probability,
                                              mutation_rate=config.mutation_rate, seed=config.seeds[0]), genome)
            for genome in config.genomes for population in config.populations]
    return budgeted_nsga2_runs(runs, coverage, teams_cache(), executor)[2]


NSGA2_COLUMNS = ["chip_id", "genome", "population", "seed", "generations", "hypervolume", "evaluations",
                 "team_lookups", "distinct_teams"]
FRONT_COLUMNS = ["chip_id", "genome", "population", "seed", "coverage_cost", "deployment_cost", "counts"]


def budgeted_nsga2_runs(runs: list[tuple[Chip, Decomposition, NSGA2Config, str]], coverage: CoverageConfig,
                        cache: EvaluationCache, executor: Executor | None = None,
                        max_teams: list[int] | None = None) -> tuple[pd.DataFrame, pd.DataFrame, list[dict]]:
    """NSGA-II runs (chip, its regions, settings, genome), each optionally stopped at a budget of distinct teams
    (`max_teams`, one per run); the tables and wall times of `nsga2_runs`."""
    budgets = max_teams or [None] * len(runs)
    tasks = [(chip, decomposition, coverage, nsga2, genome, torch.get_num_threads(), budget)
             for (chip, decomposition, nsga2, genome), budget in zip(runs, budgets, strict=True)]
    results = (executor or Executor(workers=1)).map(_nsga2_run, tasks)
    rows, fronts, seconds = [], [], []
    for (chip, _, _, nsga2, genome, _, _), (result, evaluator) in zip(tasks, results, strict=True):
        cache.merge(evaluator.cache)  # in task order: a key evaluated by two runs keeps the later run's value
        rows.append((chip.chip_id, genome, nsga2.population, nsga2.seed, nsga2.generations, result.hypervolume,
                     result.evaluations, evaluator.lookups, len(evaluator.asked)))
        seconds.append({"chip_id": chip.chip_id, "genome": genome, "population": nsga2.population,
                        "seed": nsga2.seed, "seconds": round(result.seconds, 2)})
        fronts += [(chip.chip_id, genome, nsga2.population, nsga2.seed, cost, int(deploy), counts.ravel().tolist())
                   for (cost, deploy), counts in zip(result.front, result.counts, strict=True)]
    return pd.DataFrame(rows, columns=NSGA2_COLUMNS), pd.DataFrame(fronts, columns=FRONT_COLUMNS), seconds


RANDOM_FRONT_DRAWS = (64, 512)  # Table 5.4's random-allocation fronts: the first 64 and all 512 draws


def _random_front(task: tuple[Chip, Decomposition, CoverageConfig, int, int]) -> tuple[list[tuple], list[tuple]]:
    """The random-allocation fronts of one chip and seed (an executor task): NSGA-II's initial sampler drawn
    max(RANDOM_FRONT_DRAWS) times from Generator((seed, hash of the chip id, 5401)), every allocation measured by
    the optimiser; per prefix of RANDOM_FRONT_DRAWS draws a summary row and the front's points."""
    chip, decomposition, coverage, seed, threads = task
    torch.set_num_threads(threads)
    rng = np.random.default_rng([seed, int(hashlib.sha1(chip.chip_id.encode()).hexdigest()[:12], 16), 5401])
    fractions = deployment_share_draws(rng, max(RANDOM_FRONT_DRAWS), decomposition.n_regions, len(SPECIES))
    counts = allocation_to_counts(fractions, coverage.robots_per_species)  # (S, K, O)
    evaluate = AllocationEvaluator(chip_coverage(chip, decomposition, coverage), chip.chip_id, seed)
    objectives = evaluate(counts)
    rows, points = [], []
    for draws in RANDOM_FRONT_DRAWS:
        keep = non_dominated(objectives[:draws])
        keep = keep[np.argsort(objectives[keep, 1], kind="stable")]
        rows.append((chip.chip_id, seed, draws, team_hypervolume(objectives[keep]), len(keep),
                     len(evaluate.distinct_teams(counts[:draws]))))
        points += [(chip.chip_id, seed, draws, float(cost), int(deploy), allocation.ravel().tolist())
                   for (cost, deploy), allocation in zip(objectives[keep], counts[keep], strict=True)]
    return rows, points


def random_fronts(chips: list[tuple[Chip, Decomposition]], coverage: CoverageConfig, config: ExperimentsConfig,
                  executor: Executor | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Table 5.4's random-allocation baselines on its chips and seeds: (chip_id, seed, draws, hypervolume, front
    size, distinct teams optimised for those draws; the "teams_random_points" table of the fronts' points)."""
    tasks = [(chip, decomposition, coverage, seed, torch.get_num_threads())
             for chip, decomposition in chips[:config.table_5_4_chips] for seed in config.seeds]
    results = (executor or Executor(workers=1)).map(_random_front, tasks)
    return (pd.DataFrame([row for rows, _ in results for row in rows],
                         columns=["chip_id", "seed", "draws", "hypervolume", "front_size", "distinct_teams"]),
            pd.DataFrame([point for _, points in results for point in points],
                         columns=["chip_id", "seed", "draws", "coverage_cost", "deployment_cost", "counts"]))


def baseline_draws(chip_id: str, seed: int, budgets: list[int], n_regions: int, robots_per_species: int
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The random draws of Table 5.5 on one chip and seed, from Generator((seed, hash of the chip id)):
    ((n_budgets, K, O) uniform random robots, (n_budgets, O) species counts of the joint teams, (n_budgets, K, O)
    random non-empty teams). The first two draws come first, as before the third existed, so they keep their values."""
    rng = np.random.default_rng([seed, int(hashlib.sha1(chip_id.encode()).hexdigest()[:12], 16)])
    n_species = len(SPECIES)
    allocations = np.stack([random_allocation(rng, b, n_regions, n_species, robots_per_species) for b in budgets])
    teams = np.stack([random_species_counts(rng, b, n_species, robots_per_species) for b in budgets])
    split = np.stack([random_teams(rng, b, n_regions, n_species, robots_per_species) for b in budgets])
    return allocations, teams, split


def _chip_baselines(task: tuple[Chip, Decomposition, CoverageConfig, ExperimentsConfig, int]) -> list[tuple]:
    """The Table 5.5 rows of one chip (an executor task), every seed x budget."""
    chip, decomposition, coverage, config, threads = task
    torch.set_num_threads(threads)
    problem = chip_coverage(chip, decomposition, coverage)
    n_regions = decomposition.n_regions
    rows = []
    for seed in config.seeds:
        allocations, teams, split = baseline_draws(chip.chip_id, seed, config.budgets, n_regions,
                                                   coverage.robots_per_species)
        memo = AllocationEvaluator(problem, chip.chip_id, seed)
        uniform_costs, split_costs = memo(allocations)[:, 0], memo(split)[:, 0]
        joint_costs, joint_unvisited = no_decomposition_costs(problem, teams, seed)
        for budget, uniform_cost, split_cost, joint_cost, unvisited, allocation, split_teams, team in zip(
                config.budgets, uniform_costs, split_costs, joint_costs, joint_unvisited, allocations, split, teams,
                strict=True):
            rows.append(("dec_random_allocation", chip.chip_id, budget, seed, split_cost,
                         int(deployment_cost(split_teams)), int((split_teams.sum(1) == 0).sum())))
            rows.append(("dec_uniform_robots", chip.chip_id, budget, seed, uniform_cost,
                         int(deployment_cost(allocation)), int((allocation.sum(1) == 0).sum())))
            rows.append(("no_decomposition", chip.chip_id, budget, seed, joint_cost, int(team.sum()),
                         int(unvisited)))
    return rows


def coverage_baselines(chips: list[tuple[Chip, Decomposition]], coverage: CoverageConfig,
                       config: ExperimentsConfig, executor: Executor | None = None) -> pd.DataFrame:
    """Table 5.5 baselines per chip x seed x budget: the "teams_coverage" table."""
    tasks = [(chip, decomposition, coverage, config, torch.get_num_threads())
             for chip, decomposition in chips[:config.table_5_5_chips]]
    per_chip = (executor or Executor(workers=1)).map(_chip_baselines, tasks)
    rows = [row for chip_rows in per_chip for row in chip_rows]
    return pd.DataFrame(rows, columns=["method", "chip_id", "budget", "seed", "coverage_cost",
                                       "deployment_cost", "empty_regions"])


def example_allocation(fronts: pd.DataFrame, chip_id: str, n_regions: int,
                       max_robots: int = 30) -> tuple[np.ndarray, int]:
    """((K, O) counts, seed) of the picture's example: on `chip_id`, the front point of the largest
    population with the most robots up to `max_robots` (or the fewest robots if none is that small)."""
    points = fronts[fronts.chip_id == chip_id]
    small = points[points.deployment_cost <= max_robots]
    if len(small):
        example = small.sort_values(["population", "deployment_cost", "seed"]).iloc[-1]
    else:
        example = points.sort_values(["deployment_cost", "population", "seed"]).iloc[0]
    return np.asarray(example.counts, dtype=np.int64).reshape(n_regions, -1), int(example.seed)


def example_trajectories(chip: Chip, decomposition: Decomposition, coverage: CoverageConfig,
                         counts: np.ndarray, seed: int) -> pd.DataFrame:
    """Observations of every robot of one (K, O) allocation: the "teams_trajectories" table."""
    problem = chip_coverage(chip, decomposition, coverage)
    _, robots, observations = problem.evaluate(counts[None], seed)  # (N, T, 2)
    n_robots, n_steps, _ = observations.shape
    points = observations.double().numpy()
    return pd.DataFrame({
        "chip_id": chip.chip_id,
        "robot": np.repeat(np.arange(n_robots), n_steps),
        "species": np.repeat(robots.species.numpy(), n_steps),
        "region": np.repeat(robots.team.numpy() % decomposition.n_regions, n_steps),
        "step": np.tile(np.arange(n_steps), n_robots),
        "x": points[..., 0].ravel(),
        "y": points[..., 1].ravel(),
    })
