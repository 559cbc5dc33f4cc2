"""The experiments of thesis Tables 5.4 and 5.5 on the decomposed test chips.

Table 5.4: NSGA-II with each population size, for each of the first `nsga2_chips` test chips and each
seed; the runtime is the wall time of the run with an empty evaluation cache (as the thesis times a
run from scratch); every evaluation is then merged into the stage's cache for later stages.
Table 5.5: the baselines of baselines.py at each deployment budget, for the first `baseline_chips`
test chips and each seed.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pandas as pd

from robocompose.teams.baselines import no_decomposition_costs, random_allocation, random_species_counts
from robocompose.teams.chips import Chip, read_chip
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.evaluator import AllocationEvaluator, EvaluationCache, chip_coverage
from robocompose.teams.nsga2 import NSGA2Config, run_nsga2
from robocompose.teams.params import ExperimentsConfig
from robocompose.teams.species import SPECIES, deployment_cost


def decomposed_chips(regions: pd.DataFrame, split: str) -> list[tuple[Chip, np.ndarray]]:
    """(chip, (K, 2) Voronoi seeds) of every chip of `split` in the regions table, sorted by chip id."""
    chips = []
    for chip_id, rows in regions[regions.split == split].groupby("chip_id", sort=True):
        rows = rows.sort_values("region")
        chips.append((read_chip(chip_id, rows.source.iloc[0]), rows[["seed_x", "seed_y"]].to_numpy()))
    return chips


def nsga2_runs(chips: list[tuple[Chip, np.ndarray]], coverage: CoverageConfig, config: ExperimentsConfig,
               cache: EvaluationCache) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Run NSGA-II per chip x seed x population; return the "teams_nsga2" and "teams_fronts" tables."""
    runs, fronts = [], []
    for chip, seeds in chips[:config.nsga2_chips]:
        problem = chip_coverage(chip, seeds, coverage)
        for seed in config.nsga2_seeds:
            for population in config.populations:
                evaluate = AllocationEvaluator(problem, chip.chip_id, seed)
                nsga2 = NSGA2Config(population=population, generations=config.generations,
                                    crossover_probability=config.crossover_probability,
                                    mutation_rate=config.mutation_rate, seed=seed)
                result = run_nsga2(evaluate, len(seeds), len(SPECIES), coverage.robots_per_species, nsga2)
                cache.merge(evaluate.cache)
                runs.append((chip.chip_id, population, seed, config.generations, result.hypervolume,
                             result.seconds, result.evaluations))
                fronts += [(chip.chip_id, population, seed, cost, int(deploy), counts.ravel().tolist())
                           for (cost, deploy), counts in zip(result.front, result.counts, strict=True)]
    return (pd.DataFrame(runs, columns=["chip_id", "population", "seed", "generations", "hypervolume",
                                        "seconds", "evaluations"]),
            pd.DataFrame(fronts, columns=["chip_id", "population", "seed", "coverage_cost",
                                          "deployment_cost", "counts"]))


def coverage_baselines(chips: list[tuple[Chip, np.ndarray]], coverage: CoverageConfig,
                       config: ExperimentsConfig) -> pd.DataFrame:
    """Table 5.5 baselines per chip x seed x budget: the "teams_coverage" table."""
    rows = []
    n_species, bank = len(SPECIES), coverage.robots_per_species
    for chip, seeds in chips[:config.baseline_chips]:
        problem = chip_coverage(chip, seeds, coverage)
        chip_hash = int(hashlib.sha1(chip.chip_id.encode()).hexdigest()[:12], 16)
        for seed in config.baseline_seeds:
            rng = np.random.default_rng([seed, chip_hash])
            allocations = np.stack([random_allocation(rng, b, len(seeds), n_species, bank)
                                    for b in config.budgets])  # (n_budgets, K, O)
            teams = np.stack([random_species_counts(rng, b, n_species, bank) for b in config.budgets])
            random_costs, _, _ = problem.evaluate(allocations, seed)
            joint_costs = no_decomposition_costs(problem, teams, seed)
            for budget, random_cost, joint_cost, allocation, team in zip(
                    config.budgets, random_costs, joint_costs, allocations, teams, strict=True):
                rows.append(("dec_random_allocation", chip.chip_id, budget, seed, random_cost,
                             int(deployment_cost(allocation))))
                rows.append(("no_decomposition", chip.chip_id, budget, seed, joint_cost, int(team.sum())))
    return pd.DataFrame(rows, columns=["method", "chip_id", "budget", "seed", "coverage_cost",
                                       "deployment_cost"])


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


def example_trajectories(chip: Chip, seeds: np.ndarray, coverage: CoverageConfig, counts: np.ndarray,
                         seed: int) -> pd.DataFrame:
    """Observations of every robot of one (K, O) allocation: the "teams_trajectories" table."""
    problem = chip_coverage(chip, seeds, coverage)
    _, robots, observations = problem.evaluate(counts[None], seed)  # (N, T, 2)
    n_robots, n_steps, _ = observations.shape
    points = observations.double().numpy()
    return pd.DataFrame({
        "chip_id": chip.chip_id,
        "robot": np.repeat(np.arange(n_robots), n_steps),
        "species": np.repeat(robots.species.numpy(), n_steps),
        "region": np.repeat(robots.team.numpy() % len(seeds), n_steps),
        "step": np.tile(np.arange(n_steps), n_robots),
        "x": points[..., 0].ravel(),
        "y": points[..., 1].ravel(),
    })
