"""The `modular:` section of params.yaml: evaluation settings, fitness rule, experiments, executor."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from robocompose.evaluation.cache import DEFAULT_CACHE_PATH
from robocompose.io.errors import InputError
from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.terrain import TerrainConfig
from robocompose.params import build_config, read_params


@dataclass(frozen=True)
class ExperimentsConfig:
    """What the modular stages run (thesis: 10 test terrains x 20 runs; GA 50 generations)."""

    test_terrains: list[int] = field(default_factory=lambda: [1000, 1001])  # terrain seeds (disjoint from training)
    ga_seeds: list[int] = field(default_factory=lambda: [0, 1, 2])  # independent runs per terrain and method
    generations: int = 50
    mutation_rate: float = 1 / 6  # per-port probability of a uniformly drawn new module
    crossover_rate: float = 0.9  # probability that a pair is recombined (uniform crossover) before mutation
    elite: int = 1  # GA-20/GA-50: best designs copied unchanged into the next generation
    random_designs: int = 10  # random sampling: designs per terrain and run (best kept)
    ec_draws: int = 20  # emergency-constraint draws per terrain, run and method
    near_optimal: float = 0.5  # m, the exhaustive "near-optimal" set is within this of the best (epsilon)
    gallery: int = 2  # terrains pictured with their best designs

    def __post_init__(self):
        if not self.test_terrains:
            raise InputError("test_terrains: expected at least one terrain seed")
        if self.generations < 1 or self.random_designs < 1:
            raise InputError("generations and random_designs: expected positive integers")


@dataclass(frozen=True)
class ModularParams:
    eval: EvalSettings
    fitness: FitnessRule
    experiments: ExperimentsConfig
    workers: int = 0  # local evaluation processes; 0 = all cores
    address: str = ""  # an existing Dask scheduler ("tcp://host:8786"); empty = local processes
    cache: str = str(DEFAULT_CACHE_PATH)  # the shared evaluation cache (not a DVC output)


def build_modular_params(section: dict, where: str) -> ModularParams:
    if not isinstance(section, dict):
        raise InputError(f"{where}: expected a mapping with eval, fitness, experiments, workers, address, cache")
    known = {"eval", "fitness", "experiments", "workers", "address", "cache"}
    unknown = sorted(set(section) - known)
    if unknown:
        raise InputError(f"{where}.{unknown[0]}: unknown field; expected one of {sorted(known)}")
    evaluation = section.get("eval", {})
    if not isinstance(evaluation, dict):
        raise InputError(f"{where}.eval: expected a mapping of evaluator settings, found {evaluation!r}")
    evaluation = dict(evaluation)
    terrain = build_config(TerrainConfig, evaluation.pop("terrain", {}), f"{where}.eval.terrain")
    settings = build_config(EvalSettings, evaluation, f"{where}.eval")
    workers, address = section.get("workers", 0), section.get("address", "")
    cache = section.get("cache", str(DEFAULT_CACHE_PATH))
    if not isinstance(workers, int) or workers < 0:
        raise InputError(f"{where}.workers: expected an integer >= 0 (0 = all cores), found {workers!r}")
    if not isinstance(address, str) or not isinstance(cache, str):
        raise InputError(f"{where}.address and {where}.cache: expected strings")
    return ModularParams(
        eval=EvalSettings(**{**settings.__dict__, "terrain": terrain}),
        fitness=build_config(FitnessRule, section.get("fitness", {}), f"{where}.fitness"),
        experiments=build_config(ExperimentsConfig, section.get("experiments", {}), f"{where}.experiments"),
        workers=workers, address=address, cache=cache)


def load_modular_params(path: str | Path = "params.yaml") -> ModularParams:
    """The `modular:` section of a params file, checked (errors name the file and the field)."""
    document = read_params(path)
    if "modular" not in document:
        raise InputError(f"{path}: missing section 'modular'")
    return build_modular_params(document["modular"], f"{path}: modular")
