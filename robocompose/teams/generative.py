"""Generative allocation with EG-GAN (thesis 5.2): training on the training chips, the generator file,
and the queries on held-out chips that fill Tables 5.4 and 5.5.

Training: robocompose.eggan.train (Algorithm 1) on eggan_problem.TeamsProblem over the training chips,
continuous designs (GAN loss, eq. 4.1), NSGA-II data creation, Adam at `lr` for both networks (the
group's code: 1e-3; the thesis: 1e-5 over 20 hours).
Generator file: robocompose.eggan.query's one generator format (weights, sizes, the network code digest),
with the teams world's meta: K, the design head, the settings it was trained with and its training metrics,
so `compose teams` can rebuild it and a test can check it still matches the code.
Queries: a teams learner of robocompose.eggan.learners (EG-GAN: `samples` noise vectors) on each held-out
chip and seed -> the front (`query_front`), every objective measured by the ergodic optimiser; the learner's
wall time is recorded apart (it is not reproducible, so it stays out of the DVC-hashed tables).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from robocompose.eggan.learners import Draws, generator_draws
from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.query import generator_info, save_generator
from robocompose.eggan.train import TrainConfig, Trained, train
from robocompose.io import InputError
from robocompose.search.nsga2 import non_dominated
from robocompose.teams.baselines import joint_plan
from robocompose.teams.chips import Chip
from robocompose.teams.decompose import Decomposition
from robocompose.teams.eggan_problem import DESIGN_HEAD, EvolutionConfig, TeamsProblem
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.evaluator import AllocationEvaluator, chip_coverage
from robocompose.teams.experiments import baseline_draws
from robocompose.teams.nsga2 import team_hypervolume
from robocompose.teams.params import EgganConfig
from robocompose.teams.species import allocation_to_counts


def train_config(config: EgganConfig, threads: int) -> TrainConfig:
    """The trainer's settings for `teams.eggan`."""
    return TrainConfig(iterations=config.iterations, batch=config.batch, tasks=config.tasks, evolution="nsga2",
                       evolution_steps=config.evolution_steps, lr_generator=config.lr, lr_discriminator=config.lr,
                       seed=config.seed, threads=threads, log_every=min(5, config.checkpoint_every),
                       validate_every=config.validate_every, checkpoint_every=config.checkpoint_every)


def network_config(config: EgganConfig) -> NetworkConfig:
    """3 hidden layers of 64 with layer norm and ReLU (thesis 5.2: batch norm; `robocompose.eggan.networks`), z of
    size `latent`."""
    return NetworkConfig(latent=config.latent)


def split_validation(chips: list[tuple[Chip, Decomposition]], config: EgganConfig
                     ) -> tuple[list[tuple[Chip, Decomposition]], list[tuple[Chip, Decomposition]]]:
    """(training, validation) chips: the last `validation_chips` training chips are held out for the curve."""
    if config.validation_chips >= len(chips):
        raise InputError(f"teams.eggan.validation_chips: {config.validation_chips} of {len(chips)} training chips "
                         "leaves none to train on")
    cut = len(chips) - config.validation_chips
    return chips[:cut], chips[cut:]


def validation_hypervolume(chips: list[tuple[Chip, Decomposition]], coverage: CoverageConfig, samples: int,
                           seed: int) -> Callable[[torch.nn.Module], dict[str, float]]:
    """The trainer's validation: the mean hypervolume of the generator's front from `samples` z on each validation
    chip, measured by the optimiser (one memo per chip kept across calls)."""
    evaluators = [AllocationEvaluator(chip_coverage(chip, decomposition, coverage), chip.chip_id, seed)
                  for chip, decomposition in chips]

    def validate(generator: torch.nn.Module) -> dict[str, float]:
        draws = generator_draws(generator, samples)
        fronts = [query_front(draws, chip, decomposition, coverage, seed, evaluator)
                  for (chip, decomposition), evaluator in zip(chips, evaluators, strict=True)]
        return {"validation_hypervolume": float(np.mean([front.hypervolume for front in fronts]))}

    return validate


def train_generator(chips: list[tuple[Chip, Decomposition]], coverage: CoverageConfig, config: EgganConfig,
                    evolution: EvolutionConfig, threads: int, checkpoint: Path | None = None,
                    csv_path: Path | None = None) -> tuple[Trained, TeamsProblem]:
    """Train EG-GAN on the training chips (less the validation chips), resuming from `checkpoint` if it holds
    this run."""
    training, validation = split_validation(chips, config)
    problem = TeamsProblem(training, coverage, evolution, seed=config.seed, fitness=config.fitness)
    validate = (validation_hypervolume(validation, coverage, config.validation_samples, config.seed)
                if validation and config.validate_every else None)
    trained = train(problem, network_config(config), train_config(config, threads), checkpoint, csv_path,
                    progress=True, validate=validate)
    return trained, problem


CHANCE_ACCURACY = 0.55  # a discriminator below this over the last tenth of training is flagged "at chance"


def training_summary(rows: list[dict]) -> dict:
    """What the metrics say about a training run: the discriminator's accuracy over the last tenth of the log
    and whether it stayed at chance, and the validation curve's first, best and last hypervolume."""
    tail = rows[-max(1, len(rows) // 10):]
    accuracy = float(np.mean([row["d_accuracy"] for row in tail]))
    summary = {"d_accuracy_final": round(accuracy, 4), "d_at_chance": accuracy < CHANCE_ACCURACY}
    curve = [row["validation_hypervolume"] for row in rows if not np.isnan(row.get("validation_hypervolume", np.nan))]
    if curve:
        summary.update(validation_hypervolume_first=round(curve[0], 4),
                       validation_hypervolume_best=round(max(curve), 4),
                       validation_hypervolume_last=round(curve[-1], 4))
    return summary


def rounded(values: dict, digits: int = 4) -> dict:
    """Floats rounded to `digits` significant digits (metrics files stay readable and stable)."""
    return {k: float(f"{v:.{digits}g}") if isinstance(v, float) else v for k, v in values.items()}


def save_teams_generator(trained: Trained, problem: TeamsProblem, params: dict, metrics: dict, path: Path) -> Path:
    """The generator file (robocompose.eggan.query's format) with K, the design head, the settings and metrics of
    its training, its run key and the chips it trained on (so a table can show it never saw its test chips)."""
    return save_generator(trained.generator, problem, path, {
        "n_regions": problem.n_regions, "design_head": DESIGN_HEAD, "params": params, "metrics": metrics,
        "run_key": trained.key, "train_chip_ids": [chip.chip_id for chip, _ in problem.chips]})


def teams_generator_info(path: Path) -> dict:
    """The info of a teams generator file (K, settings, metrics, provenance), checked to be one for the teams
    problem and its current design head, before the problem it fits (K regions of a chip) is built."""
    info = generator_info(path)  # the checksum first (ArtifactError naming the file); tensors and plain data only
    if info.get("problem") != TeamsProblem.name:
        raise InputError(f"{path}: not a teams generator file (a generator for {info.get('problem')!r})")
    if info.get("design_head") != DESIGN_HEAD:
        raise InputError(f"{path}: trained with design head {info.get('design_head')!r}, the code's is "
                         f"{DESIGN_HEAD!r}: retrain (stage teams_eggan)")
    return info


@dataclass
class QueryFront:
    front: np.ndarray  # (F, 2) non-dominated [coverage cost, deployment cost], by deployment cost
    counts: np.ndarray  # (F, K, O) their allocations
    hypervolume: float
    generator_seconds: float  # wall time of the learner's part (its draws: noise, forward pass; rounding)
    seconds: float  # wall time to the measured front: the learner's part and the optimiser on every draw
    distinct: int  # distinct allocations among the draws
    teams: int  # distinct teams among them: what measuring the front spends


def draw_allocations(draws: Draws, problem: TeamsProblem, seed: int) -> tuple[np.ndarray, float]:
    """The distinct (D, K, O) allocations a teams learner draws (seeded by `seed`) for `problem`'s first chip, and
    the wall time of the learner's part (noise, forward pass, rounding)."""
    started = time.perf_counter()
    counts = allocation_to_counts(np.stack(draws(problem, 0, seed)), problem.coverage.robots_per_species)  # (S, K, O)
    seconds = time.perf_counter() - started
    return np.unique(counts.reshape(len(counts), -1), axis=0).reshape(-1, *counts.shape[1:]), seconds


def query_front(draws: Draws, chip: Chip, decomposition: Decomposition, coverage: CoverageConfig, seed: int,
                evaluator: AllocationEvaluator | None = None, problem: TeamsProblem | None = None) -> QueryFront:
    """The front of one query: a teams learner's draws (seeded by `seed`) -> allocations -> objectives measured
    by the ergodic optimiser (robots' starts seeded by `seed`) -> the non-dominated set. `problem`: the chip's
    task, if already built."""
    started = time.perf_counter()
    problem = problem or TeamsProblem([(chip, decomposition)], coverage)  # the task: this chip's features
    distinct, seconds = draw_allocations(draws, problem, seed)
    evaluate = evaluator or AllocationEvaluator(chip_coverage(chip, decomposition, coverage), chip.chip_id, seed)
    objectives = evaluate(distinct)
    keep = non_dominated(objectives)
    keep = keep[np.argsort(objectives[keep, 1], kind="stable")]
    return QueryFront(objectives[keep], distinct[keep], team_hypervolume(objectives[keep]), seconds,
                      time.perf_counter() - started, len(distinct), len(evaluate.distinct_teams(distinct)))


def eggan_queries(draws: Draws, chips: list[tuple[Chip, Decomposition]], coverage: CoverageConfig,
                  seeds: list[int]) -> tuple[pd.DataFrame, pd.DataFrame, list[dict]]:
    """Query a learner's draws on every chip x seed: the "teams_eggan_queries" and "teams_eggan_fronts" tables
    and the wall times (chip_id, seed, milliseconds of the learner's part, front_seconds to the measured front)
    for the untracked timings file."""
    from tqdm import tqdm

    queries, fronts, timings = [], [], []
    for chip, decomposition in tqdm(chips, desc="eggan queries", mininterval=5.0):
        for seed in seeds:
            query = query_front(draws, chip, decomposition, coverage, seed)
            queries.append((chip.chip_id, seed, query.hypervolume, query.distinct, query.teams, len(query.front)))
            fronts += [(chip.chip_id, seed, float(cost), int(deploy), counts.ravel().tolist())
                       for (cost, deploy), counts in zip(query.front, query.counts, strict=True)]
            timings.append({"chip_id": chip.chip_id, "seed": seed,
                            "milliseconds": round(1000 * query.generator_seconds, 3),
                            "front_seconds": round(query.seconds, 3)})
    return (pd.DataFrame(queries, columns=["chip_id", "seed", "hypervolume", "distinct", "distinct_teams",
                                           "front_size"]),
            pd.DataFrame(fronts, columns=["chip_id", "seed", "coverage_cost", "deployment_cost", "counts"]),
            timings)


def coverage_examples(chips: list[tuple[Chip, Decomposition]], fronts: pd.DataFrame, coverage: CoverageConfig,
                      budget: int, seed: int) -> pd.DataFrame:
    """Fig. 5.4's observations: on each chip, at deployment budget `budget`, EG-GAN's best front allocation
    within the budget, the random non-empty teams and the joint plan of Table 5.5 (the same draws): the
    "teams_coverage_examples" table."""
    frames = []
    for chip, decomposition in chips:
        problem = chip_coverage(chip, decomposition, coverage)
        _, teams, split = baseline_draws(chip.chip_id, seed, [budget], decomposition.n_regions,
                                         coverage.robots_per_species)
        within = fronts[(fronts.chip_id == chip.chip_id) & (fronts.seed == seed) & (fronts.deployment_cost <= budget)]
        plans = {"dec_random_allocation": problem.evaluate(split, seed)[1:],
                 "no_decomposition": joint_plan(problem, teams, seed)}
        if len(within):
            best = np.asarray(within.sort_values("coverage_cost").counts.iloc[0], dtype=np.int64)
            plans["dec_eggan"] = problem.evaluate(best.reshape(1, decomposition.n_regions, -1), seed)[1:]
        for method, (robots, observations) in plans.items():
            n_robots, n_steps, _ = observations.shape
            points = observations.double().numpy()
            frames.append(pd.DataFrame({
                "method": method, "chip_id": chip.chip_id,
                "robot": np.repeat(np.arange(n_robots), n_steps),
                "species": np.repeat(robots.species.numpy(), n_steps),
                "step": np.tile(np.arange(n_steps), n_robots),
                "x": points[..., 0].ravel(), "y": points[..., 1].ravel()}))
    return pd.concat(frames, ignore_index=True)
