"""Select on one seed, report on others: every front and every chosen allocation of Tables 5.4 and 5.5 re-measured
at robot-start seeds no method selected on.

A team's coverage cost is what the ergodic optimiser reaches from random robot starts, so it depends on the start
seed (`AllocationEvaluator.seed`): a front found at seed s is a set of allocations whose costs are draws at s, and
"the best point within a budget" picked from it is, on average, luckier at s than elsewhere (the winner's curse).
Here every allocation of every method's fronts is re-measured at `heldout_seeds` (disjoint from the search seeds,
checked by `ExperimentsConfig`):
- a front's held-out hypervolume is the hypervolume of its allocations at their mean held-out cost (the same
  allocations, so points that were non-dominated by luck now fall inside others);
- Table 5.5's "best within the budget" of a front is picked at the run's own seed, and reported at the mean of its
  held-out costs; the single draws (random teams, no decomposition) are reported the same way without a pick.
The spread of a cost over the held-out seeds is the optimiser's own seed-to-seed noise, kept beside every mean.

Fronts come from three methods' tables, renamed into one: NSGA-II runs ("nsga2:<genome>:<population>", and
"nsga2-matched:..." for the runs stopped at EG-GAN's spend), random-allocation fronts ("random:<draws>") and
each EG-GAN generator's queries ("eggan:<training seed>", robocompose.teams.generators). Re-measurement runs per
chip, every distinct allocation of the chip once per held-out seed, in large optimiser batches (10 ms a team in
batches of 256, 5 ms in batches of 1,024).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
import torch

from robocompose.fanout.executor import Executor
from robocompose.search.nsga2 import NSGA2Config
from robocompose.teams.baselines import no_decomposition_costs
from robocompose.teams.chips import Chip
from robocompose.teams.decompose import Decomposition
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.evaluator import AllocationEvaluator, chip_coverage, teams_cache
from robocompose.teams.experiments import baseline_draws, budgeted_nsga2_runs
from robocompose.teams.genomes import GENOMES
from robocompose.teams.nsga2 import team_hypervolume
from robocompose.teams.params import ExperimentsConfig

HELDOUT_BATCH = 1024  # teams optimised together: the per-team cost halves from 256 to 1,024
PICK_COLUMNS = ["method", "title", "chip_id", "seed", "budget", "selected_cost", "heldout_mean", "heldout_sd",
                "deployment_cost"]
POINT_COLUMNS = ["method", "chip_id", "seed", "coverage_cost", "deployment_cost", "counts"]
SINGLE_DRAWS = {  # Table 5.5's baselines (teams/baselines.py): one draw per budget, nothing selected
    "no_decomposition": "No decomposition",
    "dec_random_allocation": "Dec + random allocation (random non-empty teams, the thesis's)",
    "dec_uniform_robots": "Dec + uniform random robots (ours: each robot to a uniform region, regions may stay "
                          "empty)",
}


def nsga2_method(genome: str, population: int, matched: bool = False) -> str:
    """The method name of NSGA-II runs: "nsga2:<genome>:<population>", "nsga2-matched:..." at EG-GAN's spend."""
    return f"nsga2{'-matched' if matched else ''}:{genome}:{population}"


def method_title(method: str) -> str:
    """A method's title in the tables (written into this stage's tables: the report reads it there)."""
    kind, *rest = method.split(":")
    if kind in ("nsga2", "nsga2-matched"):
        genome, population = rest
        return (f"NSGA-II:{population}, genome {GENOMES[genome].title}"
                + (", stopped at EG-GAN's spend" if kind == "nsga2-matched" else ""))
    if kind == "random":
        return f"random allocations, front of {rest[0]} draws"
    if kind == "eggan":
        return f"EG-GAN, generator {rest[0]}"
    return SINGLE_DRAWS[method]


def front_points(nsga2: pd.DataFrame, matched: pd.DataFrame, random: pd.DataFrame, eggan: dict[int, pd.DataFrame]
                 ) -> pd.DataFrame:
    """One table of every front point: method, chip_id, seed, coverage_cost (at the seed), deployment_cost, counts.
    `nsga2`, `matched`: "teams_fronts" rows of the full and the spend-matched runs; `random`: the random-front
    points ("teams_random_points"); `eggan`: each generator's "teams_eggan_fronts" by its training seed (method
    "eggan:<seed>")."""
    frames = [runs.assign(method=[nsga2_method(g, p, is_matched) for g, p in zip(runs.genome, runs.population,
                                                                                 strict=True)])
              for runs, is_matched in ((nsga2, False), (matched, True))]
    frames += [random.assign(method=[f"random:{draws}" for draws in random.draws]),
               *(fronts.assign(method=f"eggan:{seed}") for seed, fronts in sorted(eggan.items()))]
    return pd.concat([frame[POINT_COLUMNS] for frame in frames], ignore_index=True)


def allocation_costs(chip: Chip, decomposition: Decomposition, coverage: CoverageConfig, counts: np.ndarray,
                     seeds: list[int]) -> np.ndarray:
    """(N, H) coverage costs of one chip's (N, K, O) allocations at each of the robot-start `seeds`."""
    problem = chip_coverage(chip, decomposition, coverage)
    return np.stack([AllocationEvaluator(problem, chip.chip_id, seed, max_batch=HELDOUT_BATCH)(counts)[:, 0]
                     for seed in seeds], axis=1)


def _remeasure_chip(task: tuple[Chip, Decomposition, CoverageConfig, np.ndarray, list[int], int]) -> np.ndarray:
    """`allocation_costs` at the held-out seeds (an executor task)."""
    *problem, threads = task
    torch.set_num_threads(threads)
    return allocation_costs(*problem)


def remeasured(points: pd.DataFrame, chips: list[tuple[Chip, Decomposition]], coverage: CoverageConfig,
               seeds: list[int], executor: Executor | None = None) -> pd.DataFrame:
    """`points` with heldout_mean and heldout_sd: each allocation's coverage cost over the held-out `seeds`."""
    by_id = {chip.chip_id: (chip, decomposition) for chip, decomposition in chips}
    tasks, where = [], []
    for chip_id, rows in points.groupby("chip_id", sort=True):
        chip, decomposition = by_id[chip_id]
        flat = np.asarray(rows.counts.tolist(), dtype=np.int64)  # (n, K*O)
        distinct, inverse = np.unique(flat, axis=0, return_inverse=True)
        tasks.append((chip, decomposition, coverage, distinct.reshape(len(distinct), decomposition.n_regions, -1),
                      seeds, torch.get_num_threads()))
        where.append((rows.index, inverse.ravel()))
    mean = pd.Series(np.nan, index=points.index)
    sd = pd.Series(np.nan, index=points.index)
    for (index, inverse), costs in zip(where, (executor or Executor(workers=1)).map(_remeasure_chip, tasks),
                                       strict=True):
        mean[index] = costs.mean(1)[inverse]
        sd[index] = costs.std(1, ddof=1)[inverse]
    return points.assign(heldout_mean=mean, heldout_sd=sd)


def heldout_hypervolumes(points: pd.DataFrame) -> pd.DataFrame:
    """Per method x chip x seed: hypervolume at the selection seed, hypervolume of the same allocations at their
    held-out mean cost, and the front's size."""
    rows = []
    for (method, chip_id, seed), front in points.groupby(["method", "chip_id", "seed"], sort=True):
        found = front[["coverage_cost", "deployment_cost"]].to_numpy(dtype=np.float64)
        again = front[["heldout_mean", "deployment_cost"]].to_numpy(dtype=np.float64)
        rows.append((method, method_title(method), chip_id, seed, team_hypervolume(found), team_hypervolume(again),
                     len(front)))
    return pd.DataFrame(rows, columns=["method", "title", "chip_id", "seed", "hypervolume", "heldout_hypervolume",
                                       "front_size"])


def budget_picks(points: pd.DataFrame, budgets: list[int]) -> pd.DataFrame:
    """Table 5.5's "best within the budget" of every front: per method x chip x seed x budget, the point of lowest
    coverage cost at the selection seed among those deploying <= budget robots, with its held-out cost."""
    rows = []
    for (method, chip_id, seed), front in points.groupby(["method", "chip_id", "seed"], sort=True):
        for budget in budgets:
            within = front[front.deployment_cost <= budget]
            if not len(within):
                continue
            pick = within.loc[within.coverage_cost.idxmin()]
            rows.append((method, method_title(method), chip_id, seed, budget, pick.coverage_cost, pick.heldout_mean,
                         pick.heldout_sd, int(pick.deployment_cost)))
    return pd.DataFrame(rows, columns=PICK_COLUMNS)


def _single_draws_chip(task: tuple[Chip, Decomposition, CoverageConfig, list[int], list[int], list[int], int]
                       ) -> list[tuple]:
    """Table 5.5's single-draw baselines of one chip (the draws of `baseline_draws` at each search seed), each
    re-measured at every held-out seed (an executor task)."""
    chip, decomposition, coverage, search_seeds, budgets, heldout_seeds, threads = task
    torch.set_num_threads(threads)
    problem = chip_coverage(chip, decomposition, coverage)
    rows = []
    for seed in search_seeds:
        uniform, teams, split = baseline_draws(chip.chip_id, seed, budgets, decomposition.n_regions,
                                               coverage.robots_per_species)
        costs = {name: [] for name in SINGLE_DRAWS}
        for heldout in heldout_seeds:
            memo = AllocationEvaluator(problem, chip.chip_id, heldout, max_batch=HELDOUT_BATCH)
            costs["dec_random_allocation"].append(memo(split)[:, 0])
            costs["dec_uniform_robots"].append(memo(uniform)[:, 0])
            costs["no_decomposition"].append(no_decomposition_costs(problem, teams, heldout)[0])
        deployed = {"dec_random_allocation": split.sum((1, 2)), "dec_uniform_robots": uniform.sum((1, 2)),
                    "no_decomposition": teams.sum(1)}
        for name in SINGLE_DRAWS:
            values = np.stack(costs[name], axis=1)  # (budgets, H)
            rows += [(name, method_title(name), chip.chip_id, seed, budget, np.nan, float(v.mean()),
                      float(v.std(ddof=1)), int(deployed[name][b]))
                     for b, (budget, v) in enumerate(zip(budgets, values, strict=True))]
    return rows


def single_draw_costs(chips: list[tuple[Chip, Decomposition]], coverage: CoverageConfig, search_seeds: list[int],
                      budgets: list[int], heldout_seeds: list[int], executor: Executor | None = None
                      ) -> pd.DataFrame:
    """Table 5.5's random-team and joint-plan baselines at the held-out seeds, in `budget_picks`'s columns
    (selected_cost empty: nothing is selected)."""
    tasks = [(chip, decomposition, coverage, search_seeds, budgets, heldout_seeds, torch.get_num_threads())
             for chip, decomposition in chips]
    rows = [row for chip_rows in (executor or Executor(workers=1)).map(_single_draws_chip, tasks)
            for row in chip_rows]
    return pd.DataFrame(rows, columns=PICK_COLUMNS)


@dataclass
class Heldout:
    """What stage teams_heldout writes."""

    matched: pd.DataFrame  # "teams_nsga2" of NSGA-II stopped at EG-GAN's spend
    matched_fronts: pd.DataFrame  # "teams_fronts" of those runs
    fronts: pd.DataFrame  # "teams_heldout_fronts": every front's hypervolume at its search and the held-out seeds
    picks: pd.DataFrame  # "teams_heldout_picks": Table 5.5's picks and single draws at the held-out seeds
    metrics: dict
    matched_seconds: list[dict]  # the matched runs' wall times (not reproducible: kept apart)


def heldout_study(chips: list[tuple[Chip, Decomposition]], coverage: CoverageConfig, experiments: ExperimentsConfig,
                  nsga2: tuple[pd.DataFrame, pd.DataFrame], random: tuple[pd.DataFrame, pd.DataFrame],
                  generators: dict[int, tuple[pd.DataFrame, pd.DataFrame]], executor: Executor | None = None
                  ) -> Heldout:
    """Every front of Table 5.4 (NSGA-II's runs and fronts `nsga2`, the random fronts and their points `random`,
    each EG-GAN generator's queries and fronts by training seed) and NSGA-II stopped at EG-GAN's spend, re-measured
    at the held-out seeds on `chips`; Table 5.5's picks and single draws the same way."""
    spends = (pd.concat([queries for queries, _ in generators.values()])  # EG-GAN's spend: mean over generators
              .groupby(["chip_id", "seed"]).distinct_teams.mean())
    runs = [(chip, decomposition, NSGA2Config(population=experiments.matched_population,
                                              generations=experiments.generations,
                                              crossover_probability=experiments.crossover_probability,
                                              mutation_rate=experiments.mutation_rate, seed=seed),
             experiments.matched_genome)
            for chip, decomposition in chips for seed in experiments.seeds]
    spend = [round(spends[chip.chip_id, nsga2_config.seed]) for chip, _, nsga2_config, _ in runs]
    matched, matched_fronts, seconds = budgeted_nsga2_runs(runs, coverage, teams_cache(), executor, spend)
    points = front_points(nsga2[1], matched_fronts, random[1], {seed: fronts for seed, (_, fronts) in
                                                               generators.items()})
    points = points[points.chip_id.isin([chip.chip_id for chip, _ in chips])]
    points = remeasured(points, chips, coverage, experiments.heldout_seeds, executor)
    spent = {**{(nsga2_method(r.genome, r.population, matched=False), r.chip_id, r.seed): r.distinct_teams
                for r in nsga2[0].itertuples()},
             **{(nsga2_method(r.genome, r.population, matched=True), r.chip_id, r.seed): r.distinct_teams
                for r in matched.itertuples()},
             **{(f"eggan:{generator}", r.chip_id, r.seed): r.distinct_teams
                for generator, (queries, _) in generators.items() for r in queries.itertuples()},
             **{(f"random:{r.draws}", r.chip_id, r.seed): r.distinct_teams for r in random[0].itertuples()}}
    fronts = heldout_hypervolumes(points)
    fronts["distinct_teams"] = [spent[key] for key in zip(fronts.method, fronts.chip_id, fronts.seed, strict=True)]
    picks = pd.concat([budget_picks(points, experiments.budgets),
                       single_draw_costs(chips, coverage, experiments.seeds, experiments.budgets,
                                         experiments.heldout_seeds, executor)], ignore_index=True)
    metrics = {"search_seeds": experiments.seeds, "heldout_seeds": experiments.heldout_seeds, "chips": len(chips),
               "generators": sorted(generators),
               "heldout_hypervolume": {m: round(float(v), 4) for m, v in
                                       fronts.groupby("method").heldout_hypervolume.mean().items()},
               "cost_noise_median": round(float((picks.heldout_sd / picks.heldout_mean).median()), 4)}
    return Heldout(matched, matched_fronts, fronts, picks, metrics, seconds)
