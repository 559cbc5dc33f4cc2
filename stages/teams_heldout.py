"""DVC stage `teams_heldout`: every front of Tables 5.4 and 5.5 re-measured at robot-start seeds no method selected
on (robocompose.teams.heldout), and NSGA-II given EG-GAN's spend.

EG-GAN: the stage teams_eggan's generator and every committed generator piece of the same settings and code
(robocompose.teams.generators; stale ones are listed in the metrics, not used). NSGA-II at EG-GAN's spend: per chip x
seed, NSGA-II (`matched_genome`, `matched_population`) stopped after the generation at which it has optimised as many
distinct teams as EG-GAN's queries did there (the mean over the generators). Writes
data/teams/{matched_nsga2,matched_fronts,heldout_fronts,heldout_picks}.parquet and reports/metrics/teams_heldout.json
(the seeds, each method's mean held-out hypervolume, and the committed chip-count pieces of the current settings and
code, robocompose.teams.chip_count); the matched runs' wall times go to reports/timings.json (not
tracked by DVC).
"""

import torch

from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.io.timings import timed
from robocompose.params import load_section
from robocompose.stage import run_stage
from robocompose.teams import chip_count
from robocompose.teams.experiments import decomposed_chips
from robocompose.teams.generators import read_pieces
from robocompose.teams.heldout import heldout_study
from robocompose.teams.params import TeamsParams


def main() -> None:
    params = load_section(TeamsParams, "teams")
    torch.set_num_threads(params.threads)
    experiments = params.experiments
    chips = decomposed_chips(read_table("data/regions.parquet", "regions"), "test")[:experiments.table_5_4_chips]
    pieces, stale = read_pieces(params)
    chip_pieces, stale_chip_pieces = chip_count.read_pieces(params)
    generators = {params.eggan.seed: (read_table("data/teams/eggan_queries.parquet", "teams_eggan_queries"),
                                      read_table("data/teams/eggan_fronts.parquet", "teams_eggan_fronts")), **pieces}
    nsga2 = (read_table("data/teams/nsga2.parquet", "teams_nsga2"), read_table("data/teams/fronts.parquet",
                                                                               "teams_fronts"))
    random = (read_table("data/teams/random_fronts.parquet", "teams_random_fronts"),
              read_table("data/teams/random_points.parquet", "teams_random_points"))
    compute = load_section(ComputeConfig, "compute")
    with timed("teams_heldout") as timing, compute.executor("teams_heldout") as executor:
        study = heldout_study(chips, params.coverage, experiments, nsga2, random, generators, executor)
        timing["matched_runs"] = study.matched_seconds
        write_table(study.matched, "data/teams/matched_nsga2.parquet", "teams_nsga2")
        write_table(study.matched_fronts, "data/teams/matched_fronts.parquet", "teams_fronts")
        write_table(study.fronts, "data/teams/heldout_fronts.parquet", "teams_heldout_fronts")
        write_table(study.picks, "data/teams/heldout_picks.parquet", "teams_heldout_picks")
        atomic_write_json("reports/metrics/teams_heldout.json", {
            **study.metrics, "stale_generator_pieces": stale,
            "chip_count": [{name: piece[name] for name in chip_count.SUMMARY} for piece in chip_pieces],
            "stale_chip_count_pieces": stale_chip_pieces})


if __name__ == "__main__":
    run_stage(main)
