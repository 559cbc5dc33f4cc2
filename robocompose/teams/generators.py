"""Independent teams generators: one EG-GAN training per seed, each queried on the test chips (thesis 5.2: 5 runs).

`train_and_query` is the whole of one generator: training on the training chips (generative.train_generator) and
its queries on the first test chips at every search seed (generative.eggan_queries). Stage `teams_eggan` runs it for
`teams.eggan.seed`; further seeds are committed measurements, as the GLSO campaign's runs are:
`robocompose teams generator --seed K` runs the same function with params.yaml's `teams` section and writes
measured/teams/generators/seed-K/ (eggan_queries.parquet, eggan_fronts.parquet, piece.json). Stage `teams_heldout`
takes every piece whose key matches the current settings and code (`piece_key`: every setting that shapes a
generator or its queries, and the code its result comes from) and re-measures its fronts beside the rest; a piece of
other settings or code is reported as stale and never mixed in. A piece of the stage's own seed is skipped (the
stage's is used).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from robocompose.eggan.learners import LEARNERS
from robocompose.eggan.train import Trained
from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.io.atomic import read_json
from robocompose.io.provenance import result_digest, settings_digest
from robocompose.teams.chips import Chip
from robocompose.teams.decompose import Decomposition
from robocompose.teams.eggan_problem import EvolutionConfig, TeamsProblem
from robocompose.teams.generative import eggan_queries, rounded, train_generator, training_summary
from robocompose.teams.params import TeamsParams

PIECES = Path("measured/teams/generators")
ENTRY = "robocompose.teams.generators:train_and_query"


@dataclass
class Generated:
    """One generator's training and queries."""

    trained: Trained
    problem: TeamsProblem
    queries: pd.DataFrame  # "teams_eggan_queries"
    fronts: pd.DataFrame  # "teams_eggan_fronts"
    timings: list[dict]  # per query: chip_id, seed, milliseconds, front_seconds (not reproducible: kept apart)
    training_seconds: float


def queried_chips(test_chips: list[tuple[Chip, Decomposition]], params: TeamsParams
                  ) -> list[tuple[Chip, Decomposition]]:
    """The test chips a generator is queried on: the first of Table 5.4's and Table 5.5's chips."""
    experiments = params.experiments
    return test_chips[:max(experiments.table_5_4_chips, experiments.table_5_5_chips)]


def train_and_query(params: TeamsParams, seed: int, train_chips: list[tuple[Chip, Decomposition]],
                    test_chips: list[tuple[Chip, Decomposition]], checkpoint: Path | None = None,
                    log: Path | None = None) -> Generated:
    """Train the generator of training seed `seed` (the rest of `params.teams.eggan` as set) and query it on the
    queried test chips at every search seed."""
    experiments = params.experiments
    evolution = EvolutionConfig(experiments.crossover_probability, experiments.mutation_rate, params.eggan.archive)
    config = dataclasses.replace(params.eggan, seed=seed)
    started = time.perf_counter()
    trained, problem = train_generator(train_chips, params.coverage, config, evolution, params.threads, checkpoint,
                                       log)
    training_seconds = time.perf_counter() - started
    draws = LEARNERS["teams"]["eggan"].answer(trained.generator, config.samples)
    queries, fronts, timings = eggan_queries(draws, queried_chips(test_chips, params), params.coverage,
                                             experiments.seeds)
    return Generated(trained, problem, queries, fronts, timings, training_seconds)


def piece_key(params: TeamsParams) -> str:
    """What a generator piece must share with the current run to stand beside it: every setting that shapes a
    generator or its queries but the training seed, and the code they come from."""
    return generator_key(params, ("crossover_probability", "mutation_rate", "table_5_4_chips", "table_5_5_chips",
                                  "seeds"), ENTRY)


def generator_key(params: TeamsParams, experiments: tuple[str, ...], entry: str) -> str:
    """The key of a committed measurement made by training generators: every setting of the chips, decomposition,
    coverage and EG-GAN but the training seed, the `experiments` settings named, the threads, and the code of
    `entry`."""
    settings = {name: dataclasses.asdict(getattr(params, name)) for name in ("chips", "decompose", "coverage")}
    settings["eggan"] = {**dataclasses.asdict(params.eggan), "seed": None}
    settings["experiments"] = {name: getattr(params.experiments, name) for name in experiments}
    settings["threads"] = params.threads
    return settings_digest([settings, result_digest(entry)])


def write_piece(generated: Generated, params: TeamsParams, seed: int, root: Path = PIECES) -> Path:
    """measured/teams/generators/seed-K/: the queries, the fronts (named as the stage's own) and piece.json (key,
    seed, training summary)."""
    directory = Path(root) / f"seed-{seed}"
    directory.mkdir(parents=True, exist_ok=True)
    write_table(generated.queries, directory / "eggan_queries.parquet", "teams_eggan_queries")
    write_table(generated.fronts, directory / "eggan_fronts.parquet", "teams_eggan_fronts")
    atomic_write_json(directory / "piece.json", {
        "seed": seed, "key": piece_key(params), "distinct_teams": generated.problem.real_evaluations,
        "training_seconds": round(generated.training_seconds, 1),
        "mean_hypervolume": round(float(generated.queries.hypervolume.mean()), 4),
        **training_summary(generated.trained.rows), **rounded(generated.problem.model_error())})
    return directory


def read_pieces(params: TeamsParams, root: Path = PIECES) -> tuple[dict[int, tuple[pd.DataFrame, pd.DataFrame]],
                                                                   list[str]]:
    """({seed: (queries, fronts)} of every piece made with the current settings and code but the stage's own seed,
    [the directories of stale pieces])."""
    key, found, stale = piece_key(params), {}, []
    for directory in sorted(Path(root).glob("seed-*")):
        piece = read_json(directory / "piece.json")
        if piece.get("key") != key:
            stale.append(str(directory))
        elif piece["seed"] != params.eggan.seed:
            found[int(piece["seed"])] = (read_table(directory / "eggan_queries.parquet", "teams_eggan_queries"),
                                         read_table(directory / "eggan_fronts.parquet", "teams_eggan_fronts"))
    return found, stale
