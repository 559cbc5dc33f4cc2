"""The `eggan_modular:` section of params.yaml: EG-GAN and the learned baselines on modular robots (thesis 5.1)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.surrogate import SurrogateConfig
from robocompose.eggan.train import TrainConfig
from robocompose.modular.eggan_problem import FitnessConfig
from robocompose.params import build_config, read_params

VARIANTS = {"crowding": "EG-GAN-crowding", "ga": "EG-GAN"}  # evolution method -> the thesis's name


@dataclass(frozen=True)
class ProtocolConfig:
    """The test protocol (thesis 5.1: 10 test terrains x 20 runs)."""

    test_terrains: list[int] = field(default_factory=lambda: [1000, 1001, 1002, 1003])  # held out of training
    queries: int = 20  # independent queries per terrain and method
    candidates: int = 10  # designs every real-time method outputs per query (all simulated)
    samples: int = 64  # generator samples per query, of which the `candidates` most probable distinct are kept
    ec_draws: int = 20  # emergency-constraint draws per terrain and query

    def __post_init__(self):
        if not self.test_terrains:
            raise ValueError("protocol.test_terrains: expected at least one terrain seed")
        for name in ("queries", "candidates", "samples", "ec_draws"):
            if getattr(self, name) < 1:
                raise ValueError(f"protocol.{name}: expected a positive integer, found {getattr(self, name)}")


@dataclass(frozen=True)
class EgganModularParams:
    fitness: FitnessConfig
    network: NetworkConfig
    train: TrainConfig  # the EG-GAN variants share it; `evolution` is set per variant
    evolution_steps: dict  # variant -> n (crowding: n steps; ga: GA generations)
    protocol: ProtocolConfig
    baselines: dict  # baseline name -> its config mapping (see robocompose.eggan.<name>)


def build_eggan_modular_params(section: dict, where: str) -> EgganModularParams:
    known = {"fitness", "network", "train", "evolution_steps", "protocol", "baselines"}
    if not isinstance(section, dict):
        raise ValueError(f"{where}: expected a mapping with {sorted(known)}")
    unknown = sorted(set(section) - known)
    if unknown:
        raise ValueError(f"{where}.{unknown[0]}: unknown field; expected one of {sorted(known)}")
    fitness = dict(section.get("fitness", {}))
    surrogate = build_config(SurrogateConfig, fitness.pop("surrogate", {}), f"{where}.fitness.surrogate")
    steps = section.get("evolution_steps", {"crowding": 1, "ga": 1})
    if not isinstance(steps, dict) or set(steps) != set(VARIANTS) or not all(
            isinstance(v, int) and v >= 1 for v in steps.values()):
        raise ValueError(f"{where}.evolution_steps: expected a positive integer for each of {sorted(VARIANTS)}, "
                         f"found {steps!r}")
    baselines = section.get("baselines", {})
    if not isinstance(baselines, dict):
        raise ValueError(f"{where}.baselines: expected a mapping of baseline name -> settings")
    return EgganModularParams(
        fitness=replace(build_config(FitnessConfig, fitness, f"{where}.fitness"), surrogate=surrogate),
        network=build_config(NetworkConfig, section.get("network", {}), f"{where}.network"),
        train=build_config(TrainConfig, section.get("train", {}), f"{where}.train"),
        evolution_steps=dict(steps),
        protocol=build_config(ProtocolConfig, section.get("protocol", {}), f"{where}.protocol"),
        baselines=dict(baselines))


def load_eggan_modular_params(path: str | Path = "params.yaml") -> EgganModularParams:
    """The `eggan_modular:` section of a params file, checked (errors name the file and the field)."""
    document = read_params(path)
    if "eggan_modular" not in document:
        raise ValueError(f"{path}: missing section 'eggan_modular'")
    return build_eggan_modular_params(document["eggan_modular"], f"{path}: eggan_modular")
