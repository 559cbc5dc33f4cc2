"""The `teams:` section of params.yaml as config dataclasses (loaded by `robocompose.params.load_section`).

All five sub-sections are required: a stage must not run on defaults that the params file does not show.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from robocompose.io.errors import check_field
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

    def __post_init__(self) -> None:
        check_field(bool(self.populations) and min(self.populations) >= 2, "populations",
                    "a non-empty list of integers >= 2", self.populations)
        check_field(self.generations >= 1, "generations", "an integer >= 1", self.generations)
        for name in ("crossover_probability", "mutation_rate"):
            check_field(0 <= getattr(self, name) <= 1, name, "a probability in [0, 1]", getattr(self, name))
        for name in ("table_5_4_chips", "table_5_5_chips"):
            check_field(getattr(self, name) >= 1, name, "an integer >= 1", getattr(self, name))
        check_field(bool(self.seeds) and min(self.seeds) >= 0, "seeds", "a non-empty list of integers >= 0",
                    self.seeds)
        check_field(bool(self.budgets) and min(self.budgets) >= 1, "budgets", "a non-empty list of integers >= 1",
                    self.budgets)


@dataclass(frozen=True)
class EgganConfig:
    iterations: int = 100  # Algorithm 1 iterations (`tasks` training chips each)
    batch: int = 32  # noise vectors per iteration = |X_gen| = |X_pop|, over `tasks` tasks
    tasks: int = 4  # training chips per iteration (batch / tasks z each)
    evolution_steps: int = 1  # NSGA-II generations per iteration (the group's code: 1)
    lr: float = 1e-3  # Adam step of both networks (group's code 1e-3; thesis 1e-5 for 20 h)
    latent: int = 16  # P, the size of z (the group's code: 16)
    samples: int = 512  # noise vectors per query: the front of a task is their non-dominated set
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

    def __post_init__(self) -> None:
        check_field(self.threads >= 1, "threads", "a positive integer", self.threads)
