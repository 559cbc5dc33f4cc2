"""DVC stage `teams_eggan`: EG-GAN for teams (thesis 5.2) trained on the training chips, queried on the
held-out chips (Tables 5.4, 5.5 and Figs. 5.3, 5.4).

Writes models/teams_eggan.pt (the generator file), data/teams/eggan_{queries,fronts}.parquet,
data/teams/coverage_examples.parquet, reports/metrics/teams_eggan.json, reports/plots/teams_eggan.csv;
the checkpoint models/checkpoints/teams_eggan.pt lets a killed run resume; the generator's query wall
times go to reports/timings.json (not tracked by DVC), with NSGA-II's rows run alone on the first test chip in the
same run (Table 5.4's speed ratio). Generators of further training seeds are committed pieces
(robocompose.teams.generators), made by the same function.
"""

import dataclasses
from pathlib import Path

import torch

from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.io.timings import timed
from robocompose.params import load_section
from robocompose.stage import run_stage
from robocompose.teams.experiments import decomposed_chips, nsga2_alone
from robocompose.teams.generative import coverage_examples, rounded, save_teams_generator, training_summary
from robocompose.teams.generators import queried_chips, train_and_query
from robocompose.teams.params import TeamsParams

FIGURE_CHIPS, FIGURE_BUDGET = 3, 30  # Fig. 5.4: three test chips at deployment budget 30


def main() -> None:
    params = load_section(TeamsParams, "teams")
    torch.set_num_threads(params.threads)
    regions = read_table("data/regions.parquet", "regions")
    train_chips, test_chips = decomposed_chips(regions, "train"), decomposed_chips(regions, "test")
    experiments = params.experiments
    with timed("teams_eggan") as timing:
        generated = train_and_query(params, params.eggan.seed, train_chips, test_chips,
                                    Path("models/checkpoints/teams_eggan.pt"), Path("reports/plots/teams_eggan.csv"))
        timing["training_seconds"] = round(generated.training_seconds, 1)
        timing["queries"] = generated.timings
        timing["nsga2_alone"] = nsga2_alone(*test_chips[0], params.coverage, experiments)
        queries, fronts, trained, problem = generated.queries, generated.fronts, generated.trained, generated.problem
        write_table(queries, "data/teams/eggan_queries.parquet", "teams_eggan_queries")
        write_table(fronts, "data/teams/eggan_fronts.parquet", "teams_eggan_fronts")
        write_table(coverage_examples(queried_chips(test_chips, params)[:FIGURE_CHIPS], fronts, params.coverage,
                                      FIGURE_BUDGET, experiments.seeds[0]),
                    "data/teams/coverage_examples.parquet", "teams_coverage_examples")
        metrics = {"train_chips": len(problem.chips), "validation_chips": params.eggan.validation_chips,
                   "test_chips": queries.chip_id.nunique(), "iterations": params.eggan.iterations,
                   "distinct_teams": problem.real_evaluations, "team_lookups": problem.team_lookups,
                   "mean_hypervolume": round(float(queries.hypervolume.mean()), 4),
                   "final_pop_coverage_best": round(trained.rows[-1]["pop_coverage_cost_best"], 5),
                   **training_summary(trained.rows), **rounded(problem.model_error())}
        settings = {name: dataclasses.asdict(getattr(params, name))
                    for name in ("chips", "decompose", "coverage", "eggan")}
        settings["evolution"] = dataclasses.asdict(problem.evolution)
        save_teams_generator(trained, problem, settings, metrics, Path("models/teams_eggan.pt"))
        atomic_write_json("reports/metrics/teams_eggan.json", metrics)


if __name__ == "__main__":
    run_stage(main)
