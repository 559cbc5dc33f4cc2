"""How many training chips pay (issue 45, item 4): a generator trained on N chips, scored on the validation chips.

The pipeline trains on the training split's chips less the last `teams.eggan.validation_chips` (16 of the default
40 synthetic chips). A chip-count piece trains the same generator (every `teams` setting as set, the training seed
given) on N chips instead: the first N of those if N is smaller, else all of them and N - 16 more synthetic chips
of the same synthetic set at indices past `teams.chips.n_synthetic`, so that no extra chip is a test or a
validation chip. Its score is the mean hypervolume of the generator's front from `teams.eggan.samples` draws on
each validation chip at every search seed, every objective measured by the optimiser. Test chips are never seen.

`robocompose teams chip-count --train-chips N --seed K` writes measured/teams/chip_count/train-N-seed-K.json (key:
every setting that shapes the result, and the code of `measure`); the report tables every piece of the current key
and lists stale ones.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from robocompose.io import InputError, atomic_write_json
from robocompose.io.atomic import read_json
from robocompose.teams.chips import Chip, synthetic_chip
from robocompose.teams.decompose import Decomposition, decompose_chip
from robocompose.teams.eggan_problem import EvolutionConfig
from robocompose.teams.generative import split_validation, train_generator, training_summary, validation_hypervolume
from robocompose.teams.generators import generator_key
from robocompose.teams.params import TeamsParams

PIECES = Path("measured/teams/chip_count")
ENTRY = "robocompose.teams.chip_count:measure"
SUMMARY = ("train_chips", "seed", "validation_hypervolume", "distinct_teams", "training_seconds")  # the report's


def training_chips(params: TeamsParams, train_split: list[tuple[Chip, Decomposition]], n_chips: int
                   ) -> tuple[list[tuple[Chip, Decomposition]], list[tuple[Chip, Decomposition]]]:
    """(N training chips, the pipeline's validation chips) from the training split (sorted by chip id)."""
    if params.chips.directory:
        raise InputError(f"teams.chips.directory: {params.chips.directory!r}; the chip-count study adds synthetic "
                         "chips, so it needs the synthetic set (expected '')")
    if params.eggan.validation_chips < 1:
        raise InputError("teams.eggan.validation_chips: 0; the chip-count study scores generators on the validation "
                         "chips (expected >= 1)")
    if n_chips < 1:
        raise InputError(f"--train-chips: {n_chips}; expected an integer >= 1")
    training, validation = split_validation(train_split, params.eggan)
    extra = range(params.chips.n_synthetic, params.chips.n_synthetic + max(0, n_chips - len(training)))
    added = [synthetic_chip(params.chips.seed, index) for index in extra]
    chips = training[:n_chips] + [(chip, decompose_chip(chip, params.decompose)) for chip in added]
    return chips, validation


def measure(params: TeamsParams, train_split: list[tuple[Chip, Decomposition]], n_chips: int, seed: int,
            checkpoint: Path | None = None) -> dict:
    """Train the generator of training seed `seed` on `n_chips` chips; its validation hypervolume (mean over the
    validation chips and the search seeds), the trainer's validation curve, its spend and time."""
    chips, validation = training_chips(params, train_split, n_chips)
    config = dataclasses.replace(params.eggan, seed=seed)
    experiments = params.experiments
    evolution = EvolutionConfig(experiments.crossover_probability, experiments.mutation_rate, config.archive)
    started = time.perf_counter()
    trained, problem = train_generator(chips + validation, params.coverage, config, evolution, params.threads,
                                       checkpoint)
    seconds = time.perf_counter() - started
    per_seed = [validation_hypervolume(validation, params.coverage, config.samples, search_seed)(trained.generator)
                ["validation_hypervolume"] for search_seed in experiments.seeds]
    curve = [[row["iteration"], round(row["validation_hypervolume"], 4)] for row in trained.rows
             if not np.isnan(row.get("validation_hypervolume", np.nan))]
    return {"train_chips": n_chips, "seed": seed, "validation_chips": [chip.chip_id for chip, _ in validation],
            "validation_hypervolume": round(float(np.mean(per_seed)), 4),
            "validation_hypervolume_per_seed": [round(value, 4) for value in per_seed],
            "curve": curve, "distinct_teams": problem.real_evaluations, "training_seconds": round(seconds, 1),
            "d_accuracy_final": training_summary(trained.rows)["d_accuracy_final"]}


def piece_key(params: TeamsParams) -> str:
    """Every setting that shapes a piece but the chip count and the training seed, and the code of `measure`."""
    return generator_key(params, ("crossover_probability", "mutation_rate", "seeds"), ENTRY)


def write_piece(piece: dict, params: TeamsParams, root: Path = PIECES) -> Path:
    path = Path(root) / f"train-{piece['train_chips']}-seed-{piece['seed']}.json"
    atomic_write_json(path, {**piece, "key": piece_key(params)})
    return path


def read_pieces(params: TeamsParams, root: Path = PIECES) -> tuple[list[dict], list[str]]:
    """([every piece of the current key], [the paths of stale pieces])."""
    key, found, stale = piece_key(params), [], []
    for path in sorted(Path(root).glob("train-*-seed-*.json")):
        piece = read_json(path)
        if piece.get("key") == key:
            found.append(piece)
        else:
            stale.append(str(path))
    return found, stale
