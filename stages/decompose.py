"""DVC stage `decompose`: terrain chips -> data/teams/chips/*.png and data/regions.parquet."""

from pathlib import Path

from robocompose.io import write_table
from robocompose.report.timings import timed
from robocompose.stage import run_stage
from robocompose.teams.chips import prepare_chips
from robocompose.teams.decompose import regions_table
from robocompose.teams.params import load_teams_params


def main() -> None:
    params = load_teams_params("params.yaml")
    with timed("decompose") as timing:
        chips = prepare_chips(params.chips, Path("data/teams/chips"))
        timing["chips"] = len(chips)
        write_table(regions_table(chips, params.decompose), "data/regions.parquet", "regions")


if __name__ == "__main__":
    run_stage(main)
