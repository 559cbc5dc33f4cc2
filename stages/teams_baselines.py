"""DVC stage `teams_baselines`: NSGA-II (Table 5.4) and coverage baselines (Table 5.5) on test chips.

The baselines are robocompose.teams.baseline_runs' committed measurement (measured/teams/baselines/) while its key
matches the current settings, test chips and code, and are measured here otherwise (the log says which). The runs'
wall times go to reports/timings.json (not tracked by DVC), so the parquet outputs are byte-reproducible.
data/teams/random_{fronts,points}.parquet hold Table 5.4's random-allocation fronts (64 and 512 draws) and their
points; data/teams/team_costs.parquet records the team costs the NSGA-II runs optimised.
"""

import sys
from pathlib import Path

import torch

from robocompose.fanout.compute import ComputeConfig
from robocompose.io import read_table, write_table
from robocompose.io.timings import timed
from robocompose.params import load_section
from robocompose.stage import run_stage
from robocompose.teams.baseline_runs import PIECE, copy_piece, measure, piece_key, piece_matches, write_tables
from robocompose.teams.experiments import decomposed_chips, example_allocation, example_trajectories
from robocompose.teams.params import TeamsParams

OUT = Path("data/teams")


def main() -> None:
    params = load_section(TeamsParams, "teams")
    torch.set_num_threads(params.threads)
    test_chips = decomposed_chips(read_table("data/regions.parquet", "regions"), "test")
    compute = load_section(ComputeConfig, "compute")
    with timed("teams_baselines") as timing:
        if piece_matches(piece_key(params, test_chips)):
            timing.update(copy_piece(OUT), source=f"{PIECE}/ (committed)")
        else:
            print(f"teams_baselines: {PIECE}/ holds no piece of these settings, chips and code: measuring the "
                  "baselines (`robocompose teams baselines` commits them)", file=sys.stderr)
            with compute.executor("teams_baselines") as executor:
                runs = measure(test_chips, params, executor)
            write_tables(runs, OUT)
            timing.update(runs.timings, source="measured")
        chip, decomposition = test_chips[0]
        fronts = read_table(OUT / "fronts.parquet", "teams_fronts")
        counts, seed = example_allocation(fronts, chip.chip_id, decomposition.n_regions)
        write_table(example_trajectories(chip, decomposition, params.coverage, counts, seed),
                    OUT / "trajectories.parquet", "teams_trajectories")


if __name__ == "__main__":
    run_stage(main)
