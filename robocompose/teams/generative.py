"""Generative allocation with EG-GAN (thesis 5.2): training on the training chips, the generator file,
and the queries on held-out chips that fill Tables 5.4 and 5.5.

Training: robocompose.eggan.train (Algorithm 1) on eggan_problem.TeamsProblem over the training chips,
continuous designs (GAN loss, eq. 4.1), NSGA-II data creation, Adam at `lr` for both networks (the
group's code: 1e-3; the thesis: 1e-5 over 20 hours).
Generator file: the generator's weights with the network sizes, K, the settings it was trained with,
its training metrics and the code digest of the network module, so `compose teams` can rebuild it and
a test can check it still matches the code.
Queries: on each held-out chip and seed, `samples` noise vectors -> the front (eggan_problem.query_front),
every objective measured by the ergodic optimiser; the generator's wall time is recorded apart (it is
not reproducible, so it stays out of the DVC-hashed tables).
"""

from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path

import numpy as np
import pandas as pd

from robocompose.eggan.networks import Generator, NetworkConfig
from robocompose.eggan.train import TrainConfig, Trained, train
from robocompose.io import InputError
from robocompose.io.provenance import ROOT
from robocompose.io.torch_file import load_torch, save_torch
from robocompose.teams.baselines import joint_plan
from robocompose.teams.chips import Chip
from robocompose.teams.decompose import Decomposition
from robocompose.teams.eggan_problem import DESIGN_HEAD, EvolutionConfig, TeamsProblem, query_front
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.evaluator import chip_coverage
from robocompose.teams.experiments import baseline_draws
from robocompose.teams.params import EgganConfig
from robocompose.teams.species import SPECIES

MODEL_CODE = "robocompose/eggan/networks.py"  # the code a generator file's weights belong to


def model_code_digest() -> str:
    """SHA-256 (16 hex digits) of the network module's own source: the architecture the weights fit."""
    return hashlib.sha256((ROOT / MODEL_CODE).read_bytes()).hexdigest()[:16]


def train_config(config: EgganConfig, threads: int) -> TrainConfig:
    """The trainer's settings for `teams.eggan`."""
    return TrainConfig(iterations=config.iterations, batch=config.batch, tasks=config.tasks, evolution="nsga2",
                       evolution_steps=config.evolution_steps, lr_generator=config.lr, lr_discriminator=config.lr,
                       seed=config.seed, threads=threads, log_every=min(5, config.checkpoint_every),
                       checkpoint_every=config.checkpoint_every)


def network_config(config: EgganConfig) -> NetworkConfig:
    """3 hidden layers of 64 with batch norm and ReLU (thesis 5.2), z of size `latent`."""
    return NetworkConfig(latent=config.latent)


def train_generator(chips: list[tuple[Chip, Decomposition]], coverage: CoverageConfig, config: EgganConfig,
                    evolution: EvolutionConfig, threads: int, checkpoint: Path | None = None,
                    csv_path: Path | None = None) -> tuple[Trained, TeamsProblem]:
    """Train EG-GAN on the training chips, resuming from `checkpoint` if it holds this run."""
    problem = TeamsProblem(chips, coverage, evolution, seed=config.seed)
    trained = train(problem, network_config(config), train_config(config, threads), checkpoint, csv_path,
                    progress=True)
    return trained, problem


def save_generator(trained: Trained, n_regions: int, params: dict, metrics: dict, path: Path) -> None:
    """The generator file: weights, sizes, K, the settings and metrics of its training, the code digest."""
    save_torch({"generator": trained.generator.state_dict(), "network": dataclasses.asdict(trained.network),
                "n_regions": n_regions, "n_species": len(SPECIES), "params": params, "metrics": metrics,
                "code_digest": model_code_digest(), "design_head": DESIGN_HEAD, "run_key": trained.key}, path)


def load_generator(path: Path) -> tuple[Generator, dict]:
    """(the generator in eval mode, the file's contents without the weights); a clear error if unusable."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such generator file (expected one written by the teams_eggan stage)")
    saved = load_torch(path)  # the checksum first (ArtifactError naming the file); tensors and plain data only
    if not isinstance(saved, dict) or "generator" not in saved or "network" not in saved:
        raise InputError(f"{path}: not a teams generator file (expected keys generator, network, n_regions)")
    if saved.get("design_head") != DESIGN_HEAD:
        raise InputError(f"{path}: trained with design head {saved.get('design_head')!r}, the code's is "
                         f"{DESIGN_HEAD!r}: retrain (stage teams_eggan)")
    k, o = saved["n_regions"], saved["n_species"]
    generator = Generator((k * 4,), (k + 1, o), NetworkConfig(**saved["network"]))
    generator.load_state_dict(saved["generator"])
    return generator.eval(), {key: value for key, value in saved.items() if key != "generator"}


def eggan_queries(generator: Generator, chips: list[tuple[Chip, Decomposition]], coverage: CoverageConfig,
                  samples: int, seeds: list[int]) -> tuple[pd.DataFrame, pd.DataFrame, list[dict]]:
    """Query every chip x seed: the "teams_eggan_queries" and "teams_eggan_fronts" tables and the
    generator's wall times (chip_id, seed, milliseconds) for the untracked timings file."""
    from tqdm import tqdm

    queries, fronts, timings = [], [], []
    for chip, decomposition in tqdm(chips, desc="eggan queries", mininterval=5.0):
        for seed in seeds:
            query = query_front(generator, chip, decomposition, coverage, samples, seed)
            queries.append((chip.chip_id, seed, query.hypervolume, query.distinct, len(query.front)))
            fronts += [(chip.chip_id, seed, float(cost), int(deploy), counts.ravel().tolist())
                       for (cost, deploy), counts in zip(query.front, query.counts, strict=True)]
            timings.append({"chip_id": chip.chip_id, "seed": seed,
                            "milliseconds": round(1000 * query.generator_seconds, 3)})
    return (pd.DataFrame(queries, columns=["chip_id", "seed", "hypervolume", "distinct", "front_size"]),
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
