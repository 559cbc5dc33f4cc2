"""DVC stage `teams_baselines`: NSGA-II (Table 5.4) and coverage baselines (Table 5.5) on test chips.

The runs' wall times go to reports/timings.json (not tracked by DVC), so the parquet outputs are
byte-reproducible. data/teams/random_{fronts,points}.parquet hold Table 5.4's random-allocation fronts (64 and
512 draws) and their points. data/teams/team_costs.parquet records the team costs the NSGA-II runs optimised.
"""

import torch

from robocompose.fanout.compute import ComputeConfig
from robocompose.io import read_table, write_table
from robocompose.io.timings import timed
from robocompose.params import load_section
from robocompose.stage import run_stage
from robocompose.teams.evaluator import teams_cache
from robocompose.teams.experiments import (
    coverage_baselines,
    decomposed_chips,
    example_allocation,
    example_trajectories,
    nsga2_runs,
    random_fronts,
)
from robocompose.teams.params import TeamsParams


def main() -> None:
    params = load_section(TeamsParams, "teams")
    torch.set_num_threads(params.threads)
    test_chips = decomposed_chips(read_table("data/regions.parquet", "regions"), "test")
    cache = teams_cache()  # the NSGA-II runs' team costs, each run's memo merged (a record: no stage reads it)
    experiments = params.experiments
    compute = load_section(ComputeConfig, "compute")
    with timed("teams_baselines") as timing, compute.executor("teams_baselines") as executor:
        runs, fronts, run_timings = nsga2_runs(test_chips, params.coverage, experiments, cache, executor)
        timing.update(run_timings)
        coverage = coverage_baselines(test_chips, params.coverage, experiments, executor)
        random, random_points = random_fronts(test_chips, params.coverage, experiments, executor)
        write_table(random, "data/teams/random_fronts.parquet", "teams_random_fronts")
        write_table(random_points, "data/teams/random_points.parquet", "teams_random_points")
        write_table(cache.frame(), "data/teams/team_costs.parquet", "teams_team_costs")
        write_table(runs, "data/teams/nsga2.parquet", "teams_nsga2")
        write_table(fronts, "data/teams/fronts.parquet", "teams_fronts")
        write_table(coverage, "data/teams/coverage.parquet", "teams_coverage")
        chip, decomposition = test_chips[0]
        counts, seed = example_allocation(fronts, chip.chip_id, decomposition.n_regions)
        write_table(example_trajectories(chip, decomposition, params.coverage, counts, seed),
                    "data/teams/trajectories.parquet", "teams_trajectories")


if __name__ == "__main__":
    run_stage(main)
