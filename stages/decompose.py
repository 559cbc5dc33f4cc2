"""DVC stage `decompose`: terrain chips -> data/teams/chips/*.png, data/regions.parquet and the
region purity of the terrain-driven decomposition against the plain Voronoi (data/teams/purity.parquet,
reports/metrics/decompose.json)."""

from pathlib import Path

from robocompose.io import atomic_write_json, write_table
from robocompose.io.timings import timed
from robocompose.params import load_section
from robocompose.stage import run_stage
from robocompose.teams.chips import prepare_chips
from robocompose.teams.decompose import purity_table, regions_table
from robocompose.teams.params import TeamsParams


def main() -> None:
    params = load_section(TeamsParams, "teams")
    with timed("decompose") as timing:
        chips = prepare_chips(params.chips, Path("data/teams/chips"))
        timing["chips"] = len(chips)
        write_table(regions_table(chips, params.decompose), "data/regions.parquet", "regions")
        purity = purity_table(chips, params.decompose)
        write_table(purity, "data/teams/purity.parquet", "regions_purity")
        atomic_write_json("reports/metrics/decompose.json", {
            "mean_purity": {method: round(float(group.purity.mean()), 4)
                            for method, group in purity.groupby("method")},
            "chips": int(purity.chip_id.nunique()), "terrain_weight": params.decompose.terrain_weight})


if __name__ == "__main__":
    run_stage(main)
