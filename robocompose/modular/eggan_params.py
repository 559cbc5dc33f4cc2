"""The `eggan_modular:` section of params.yaml (loaded by `robocompose.params.load_section`): EG-GAN and the
learned baselines on modular robots (thesis 5.1)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from robocompose.eggan.learners import baselines, variants
from robocompose.eggan.networks import ENCODERS, NetworkConfig
from robocompose.eggan.train import TrainConfig
from robocompose.io.errors import InputError, check_field
from robocompose.modular.diverse import check_min_hamming
from robocompose.modular.plugins.eggan_problem import FitnessConfig
from robocompose.params import build_config


@dataclass(frozen=True)
class ProtocolConfig:
    """The test protocol (thesis 5.1: 10 test terrains x 20 runs)."""

    test_terrains: list[int] = field(default_factory=lambda: [1000, 1001, 1002, 1003])  # held out of training
    queries: int = 20  # independent queries per terrain and method
    candidates: int = 10  # designs every real-time method outputs per query (all simulated)
    samples: int = 64  # generator samples per query, of which the `candidates` most probable distinct are kept
    ec_draws: int = 20  # emergency-constraint draws per terrain and query
    # the diverse query's row (EG-GAN-crowding's generator): candidates pairwise at Hamming distance >= this
    diverse_hamming: int = 2

    def __post_init__(self):
        if not self.test_terrains:
            raise InputError("test_terrains: expected at least one terrain seed")
        for name in ("queries", "candidates", "samples", "ec_draws"):
            check_field(getattr(self, name) >= 1, name, "a positive integer", getattr(self, name))
        check_min_hamming(self.diverse_hamming, "diverse_hamming")


@dataclass(frozen=True)
class PoolSizeConfig:
    """The pool-size study (`robocompose.modular.experiments.pool_size`)."""

    sizes: list[int] = field(default_factory=lambda: [8, 16, 32, 40])  # training terrains (capped at the pool's)
    iterations: int = 1000  # EG-GAN-crowding iterations per size (or until the look-up budget is spent)
    queries: int = 5  # test queries per terrain and method
    seeds: int = 2  # EG-GAN-crowding training seeds per size (train.seed, train.seed + 1, ...)

    def __post_init__(self):
        check_field(bool(self.sizes) and all(isinstance(n, int) and n >= 1 for n in self.sizes),
                    "eggan_modular.pool_size.sizes", "a list of positive integers", self.sizes)
        for name in ("iterations", "queries", "seeds"):
            value = getattr(self, name)
            check_field(value >= 1, f"eggan_modular.pool_size.{name}", "a positive integer", value)


@dataclass(frozen=True)
class EgganModularParams:
    fitness: FitnessConfig = field(default_factory=FitnessConfig)
    network: NetworkConfig = field(default_factory=NetworkConfig)
    # learner name -> its terrain encoder where it is not `network.encoder` (each learner at its best: chosen per
    # learner on the validation terrains, docs/eggan.md); the other network settings are shared
    encoders: dict = field(default_factory=dict)
    train: TrainConfig = field(default_factory=TrainConfig)  # the EG-GAN variants share it; `evolution` set per variant
    # per EG-GAN variant (learners.variants): crowding steps; ga: GA generations
    evolution_steps: dict = field(default_factory=lambda: dict.fromkeys(variants("modular"), 1))
    protocol: ProtocolConfig = field(default_factory=ProtocolConfig)
    # learned baseline name -> the mapping of its registry entry's settings dataclass (robocompose.eggan.<name>)
    baselines: dict = field(default_factory=lambda: {name: {} for name in baselines("modular")})
    pool_size: PoolSizeConfig = field(default_factory=PoolSizeConfig)

    def __post_init__(self) -> None:
        learners = [*variants("modular"), *baselines("modular")]
        check_field(isinstance(self.encoders, dict) and set(self.encoders) <= set(learners)
                    and all(encoder in ENCODERS for encoder in self.encoders.values()), "encoders",
                    f"a mapping of learners among {learners} to an encoder among {list(ENCODERS)}", self.encoders)
        steps, known = self.evolution_steps, sorted(variants("modular"))
        check_field(set(steps) == set(known) and all(isinstance(v, int) and not isinstance(v, bool) and v >= 1
                                                     for v in steps.values()),
                    "evolution_steps", f"a positive integer for each of {known}", steps)
        # Each baseline's settings are checked here, so that `robocompose profile` refuses a bad one before any
        # stage runs; the trainer builds its dataclass again from the same mapping.
        learned = baselines("modular")
        check_field(isinstance(self.baselines, dict) and set(self.baselines) == set(learned), "baselines",
                    f"a settings mapping for each of {list(learned)}", sorted(self.baselines, key=str))
        for name, values in self.baselines.items():
            build_config(learned[name].training.settings, values, f"baselines.{name}")


def network_of(method: str, params: EgganModularParams) -> NetworkConfig:
    """The network settings learner `method` trains with: `params.network`, its encoder from `params.encoders` if
    set there."""
    encoder = params.encoders.get(method, params.network.encoder)
    return params.network if encoder == params.network.encoder else dataclasses.replace(params.network,
                                                                                        encoder=encoder)
