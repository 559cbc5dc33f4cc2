"""The `teams:` section of params.yaml, parsed into the config dataclasses and checked.

An unknown key, a missing section or a value of the wrong type fails with the file, the field and
what was expected.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from robocompose.params import build_config, read_params
from robocompose.teams.chips import ChipsConfig
from robocompose.teams.decompose import DecomposeConfig
from robocompose.teams.ergodic import CoverageConfig


@dataclass(frozen=True)
class ExperimentsConfig:
    populations: list[int] = field(default_factory=lambda: [20, 50])  # NSGA-II population sizes
    generations: int = 50  # NSGA-II generations
    crossover_probability: float = 0.5  # NSGA-II single-point arithmetic crossover probability
    mutation_rate: float = 0.1  # NSGA-II per-gene uniform mutation rate
    table_5_4_chips: int = 2  # Table 5.4 (NSGA-II:20, :50, EG-GAN) on the first test chips (by id) ...
    table_5_5_chips: int = 20  # Table 5.5 (no decomposition, random, EG-GAN) on the first test chips ...
    seeds: list[int] = field(default_factory=lambda: [0])  # ... each row of a table on these seeds
    budgets: list[int] = field(default_factory=lambda: [15, 30, 45])  # Table 5.5 deployment budgets
    workers: int = 0  # processes running the independent runs; 0 = all cores, 1 = in the stage's process
    address: str = ""  # a running Dask scheduler (e.g. tcp://10.0.0.5:8786) to fan out over; "" = local

    def __post_init__(self) -> None:
        if min(self.table_5_4_chips, self.table_5_5_chips) < 1 or not self.seeds:
            raise ValueError(f"table_5_4_chips, table_5_5_chips, seeds: expected >= 1 chip each and a "
                             f"non-empty seed list, found {self.table_5_4_chips}, {self.table_5_5_chips}, "
                             f"{self.seeds}")
        if self.workers < 0:
            raise ValueError(f"workers: expected >= 0 (0 = all cores), found {self.workers}")


@dataclass(frozen=True)
class EgganConfig:
    iterations: int = 100  # Algorithm 1 iterations (`tasks` training chips each)
    batch: int = 32  # noise vectors per iteration = |X_gen| = |X_pop|, over `tasks` tasks
    tasks: int = 4  # training chips per iteration (batch / tasks z each; several, so batch norm keeps the task)
    evolution_steps: int = 1  # NSGA-II generations per iteration (the group's code: 1)
    lr: float = 1e-3  # Adam step of both networks (group's code 1e-3; thesis 1e-5 for 20 h)
    latent: int = 16  # P, the size of z (the group's code: 16)
    samples: int = 64  # noise vectors per query (the front of a task)
    seed: int = 0  # seeds training
    checkpoint_every: int = 25  # iterations between checkpoints


@dataclass(frozen=True)
class TeamsParams:
    chips: ChipsConfig
    decompose: DecomposeConfig
    coverage: CoverageConfig
    experiments: ExperimentsConfig
    eggan: EgganConfig
    threads: int = 1  # torch threads: the tensors are small, one thread is fastest and reproducible


def load_teams_params(path: str | Path = "params.yaml") -> TeamsParams:
    """Read the `teams:` section of a params file."""
    section = read_params(path).get("teams")
    where = f"{path}: teams"
    if not isinstance(section, dict):
        raise ValueError(f"{where}: missing section (expected chips, decompose, coverage, experiments, eggan)")
    parts = {"chips": ChipsConfig, "decompose": DecomposeConfig, "coverage": CoverageConfig,
             "experiments": ExperimentsConfig, "eggan": EgganConfig}
    known = sorted([*parts, "threads"])
    unknown = sorted(set(section) - set(known))
    if unknown:
        raise ValueError(f"{where}.{unknown[0]}: unknown field; expected one of {known}")
    built = {name: build_config(cls, section.get(name, {}), f"{where}.{name}") for name, cls in parts.items()}
    threads = section.get("threads", 1)
    if not isinstance(threads, int) or threads < 1:
        raise ValueError(f"{where}.threads: expected a positive integer, found {threads!r}")
    return TeamsParams(**built, threads=threads)
