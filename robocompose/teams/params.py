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
    genomes: list[str] = field(default_factory=lambda: ["fractions"])  # NSGA-II genomes (teams.nsga2.GENOMES)
    generations: int = 50  # NSGA-II generations
    crossover_probability: float = 0.5  # NSGA-II single-point arithmetic crossover probability
    mutation_rate: float = 0.1  # NSGA-II per-gene uniform mutation rate
    table_5_4_chips: int = 2  # Table 5.4 (NSGA-II:20, :50, EG-GAN) on the first test chips (by id) ...
    table_5_5_chips: int = 20  # Table 5.5 (no decomposition, random, EG-GAN) on the first test chips ...
    seeds: list[int] = field(default_factory=lambda: [0])  # ... each row of a table on these seeds
    budgets: list[int] = field(default_factory=lambda: [15, 30, 45])  # Table 5.5 deployment budgets
    heldout_seeds: list[int] = field(default_factory=lambda: [100, 101, 102])  # robot starts that re-measure
    # every front and pick (teams/heldout.py): never one of `seeds`, on which the methods selected
    matched_genome: str = "share_split"  # NSGA-II given EG-GAN's spend: its genome ...
    matched_population: int = 20  # ... and population, stopped once it optimised as many teams as EG-GAN's query

    def __post_init__(self) -> None:
        check_field(bool(self.populations) and min(self.populations) >= 2, "populations",
                    "a non-empty list of integers >= 2", self.populations)
        from robocompose.teams.genomes import GENOMES

        check_field(bool(self.genomes) and set(self.genomes) <= set(GENOMES) and len(set(self.genomes)) ==
                    len(self.genomes), "genomes", f"a non-empty list of distinct names from {sorted(GENOMES)}",
                    self.genomes)
        check_field(self.generations >= 1, "generations", "an integer >= 1", self.generations)
        for name in ("crossover_probability", "mutation_rate"):
            check_field(0 <= getattr(self, name) <= 1, name, "a probability in [0, 1]", getattr(self, name))
        for name in ("table_5_4_chips", "table_5_5_chips"):
            check_field(getattr(self, name) >= 1, name, "an integer >= 1", getattr(self, name))
        check_field(bool(self.seeds) and min(self.seeds) >= 0, "seeds", "a non-empty list of integers >= 0",
                    self.seeds)
        check_field(bool(self.budgets) and min(self.budgets) >= 1, "budgets", "a non-empty list of integers >= 1",
                    self.budgets)
        check_field(len(set(self.heldout_seeds)) >= 2 and min(self.heldout_seeds) >= 0
                    and not set(self.heldout_seeds) & set(self.seeds), "heldout_seeds",
                    f"at least 2 distinct integers >= 0, none of the search seeds {self.seeds}", self.heldout_seeds)
        check_field(self.matched_genome in GENOMES, "matched_genome", f"one of {sorted(GENOMES)}",
                    self.matched_genome)
        check_field(self.matched_population >= 2, "matched_population", "an integer >= 2", self.matched_population)


SOURCES = ("exact", "model")


@dataclass(frozen=True)
class TeamFitnessConfig:
    """Where EG-GAN training's team costs come from (robocompose.teams.eggan_problem says how)."""

    source: str = "exact"  # "exact": the optimiser for every team; "model": a learned region-cost model steers
    warmup: int = 64  # random allocations per training chip optimised before the first fit (model)
    real_every: int = 50  # evaluate calls between rounds: the call's unknown teams optimised, the model refitted
    budget: int = 50_000  # teams the optimiser may run for training (model); then the model alone answers
    seed: int = 0  # the warm-up draws and the model's fits

    def __post_init__(self) -> None:
        check_field(self.source in SOURCES, "source", f"one of {list(SOURCES)}", self.source)
        for name in ("warmup", "real_every", "budget"):
            check_field(isinstance(getattr(self, name), int) and getattr(self, name) >= 1, name,
                        "a positive integer", getattr(self, name))


@dataclass(frozen=True)
class EgganConfig:
    iterations: int = 100  # Algorithm 1 iterations (`tasks` training chips each)
    batch: int = 32  # noise vectors per iteration = |X_gen| = |X_pop|, over `tasks` tasks
    tasks: int = 4  # training chips per iteration (batch / tasks z each: NSGA-II's population per chip)
    evolution_steps: int = 1  # NSGA-II generations per iteration (the group's code: 1)
    lr: float = 1e-3  # Adam step of both networks (group's code 1e-3; thesis 1e-5 for 20 h)
    latent: int = 16  # P, the size of z (the group's code: 16)
    samples: int = 512  # noise vectors per query: the front of a task is their non-dominated set
    seed: int = 0  # seeds training
    checkpoint_every: int = 25  # iterations between checkpoints
    fitness: TeamFitnessConfig = field(default_factory=TeamFitnessConfig)  # training's team costs
    archive: bool = False  # data creation evolves X_gen with the chip's last X_pop (eggan_problem.py), not alone
    validation_chips: int = 0  # the last training chips (by id), held out of training for the validation curve
    validate_every: int = 0  # iterations between validation hypervolumes (a multiple of 5; 0: none)
    validation_samples: int = 64  # noise vectors per validation query (fronts measured by the optimiser)

    def __post_init__(self) -> None:
        check_field(self.validation_chips >= 0, "validation_chips", "an integer >= 0", self.validation_chips)
        check_field(self.validate_every >= 0 and self.validate_every % 5 == 0, "validate_every",
                    "0 or a multiple of 5 (the log's rows)", self.validate_every)
        check_field(self.validation_samples >= 1, "validation_samples", "a positive integer",
                    self.validation_samples)


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
