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

import pandas as pd
import torch

from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.io.timings import timed
from robocompose.params import load_section
from robocompose.search.nsga2 import NSGA2Config
from robocompose.stage import run_stage
from robocompose.teams import chip_count
from robocompose.teams.evaluator import teams_cache
from robocompose.teams.experiments import budgeted_nsga2_runs, decomposed_chips
from robocompose.teams.generators import read_pieces
from robocompose.teams.heldout import (
    budget_picks,
    front_points,
    heldout_hypervolumes,
    nsga2_method,
    remeasured,
    single_draw_costs,
)
from robocompose.teams.params import TeamsParams


def main() -> None:
    params = load_section(TeamsParams, "teams")
    torch.set_num_threads(params.threads)
    experiments = params.experiments
    chips = decomposed_chips(read_table("data/regions.parquet", "regions"), "test")[:experiments.table_5_4_chips]
    nsga2 = read_table("data/teams/nsga2.parquet", "teams_nsga2")
    pieces, stale = read_pieces(params)
    chip_pieces, stale_chip_pieces = chip_count.read_pieces(params)
    generators = {params.eggan.seed: (read_table("data/teams/eggan_queries.parquet", "teams_eggan_queries"),
                                      read_table("data/teams/eggan_fronts.parquet", "teams_eggan_fronts")), **pieces}
    spends = (pd.concat([queries for queries, _ in generators.values()])  # EG-GAN's spend: mean over generators
              .groupby(["chip_id", "seed"]).distinct_teams.mean())
    compute = load_section(ComputeConfig, "compute")
    with timed("teams_heldout") as timing, compute.executor("teams_heldout") as executor:
        runs = [(chip, decomposition, NSGA2Config(population=experiments.matched_population,
                                                  generations=experiments.generations,
                                                  crossover_probability=experiments.crossover_probability,
                                                  mutation_rate=experiments.mutation_rate, seed=seed),
                 experiments.matched_genome)
                for chip, decomposition in chips for seed in experiments.seeds]
        spend = [round(spends[chip.chip_id, nsga2_config.seed]) for chip, _, nsga2_config, _ in runs]
        matched, matched_fronts, timing["matched_runs"] = budgeted_nsga2_runs(runs, params.coverage, teams_cache(),
                                                                              executor, spend)
        points = front_points(read_table("data/teams/fronts.parquet", "teams_fronts"), matched_fronts,
                              read_table("data/teams/random_points.parquet", "teams_random_points"),
                              {seed: fronts for seed, (_, fronts) in generators.items()})
        points = points[points.chip_id.isin([chip.chip_id for chip, _ in chips])]
        points = remeasured(points, chips, params.coverage, experiments.heldout_seeds, executor)
        spent = {**{(nsga2_method(r.genome, r.population, matched=False), r.chip_id, r.seed): r.distinct_teams
                    for r in nsga2.itertuples()},
                 **{(nsga2_method(r.genome, r.population, matched=True), r.chip_id, r.seed): r.distinct_teams
                    for r in matched.itertuples()},
                 **{(f"eggan:{generator}", r.chip_id, r.seed): r.distinct_teams
                    for generator, (queries, _) in generators.items() for r in queries.itertuples()}}
        random = read_table("data/teams/random_fronts.parquet", "teams_random_fronts")
        spent |= {(f"random:{r.draws}", r.chip_id, r.seed): r.distinct_teams for r in random.itertuples()}
        fronts = heldout_hypervolumes(points)
        fronts["distinct_teams"] = [spent[key] for key in zip(fronts.method, fronts.chip_id, fronts.seed,
                                                              strict=True)]
        picks = budget_picks(points, experiments.budgets)
        single = single_draw_costs(chips, params.coverage, experiments.seeds, experiments.budgets,
                                   experiments.heldout_seeds, executor)
        write_table(matched, "data/teams/matched_nsga2.parquet", "teams_nsga2")
        write_table(matched_fronts, "data/teams/matched_fronts.parquet", "teams_fronts")
        write_table(fronts, "data/teams/heldout_fronts.parquet", "teams_heldout_fronts")
        picks = pd.concat([picks, single], ignore_index=True)
        write_table(picks, "data/teams/heldout_picks.parquet", "teams_heldout_picks")
        atomic_write_json("reports/metrics/teams_heldout.json", {
            "search_seeds": experiments.seeds, "heldout_seeds": experiments.heldout_seeds, "chips": len(chips),
            "generators": sorted(generators), "stale_generator_pieces": stale,
            "heldout_hypervolume": {m: round(float(v), 4) for m, v in
                                    fronts.groupby("method").heldout_hypervolume.mean().items()},
            "cost_noise_median": round(float((picks.heldout_sd / picks.heldout_mean).median()), 4),
            "chip_count": [{name: piece[name] for name in chip_count.SUMMARY} for piece in chip_pieces],
            "stale_chip_count_pieces": stale_chip_pieces})


if __name__ == "__main__":
    run_stage(main)
