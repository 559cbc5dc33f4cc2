"""The `modular:` section of params.yaml (loaded by `robocompose.params.load_section`): evaluation settings, the
fitness rule and the experiments."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from robocompose.io.errors import InputError
from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.robot import LINK_LENGTH, PORT_XY, SHOULDER_OFFSET, WHEEL_RADIUS, X8_3

FASTEST_SPEED = WHEEL_RADIUS * X8_3.speed  # m/s, a wheel's rim at the drive's rated speed (0.92; measured 0.91)
FRONT_REACH = PORT_XY[0][0] + SHOULDER_OFFSET + LINK_LENGTH  # m, the farthest a module reaches ahead of the chassis
TEST_SEED_BLOCK = range(1000, 2000)  # terrain seeds reserved for testing: no training terrain is drawn from them


@dataclass(frozen=True)
class ExperimentsConfig:
    """What the modular stages run (thesis: 10 test terrains x 20 runs; GA 50 generations)."""

    # Held-out test terrains: seeds never used for training (a generator trains on seeds outside TEST_SEED_BLOCK).
    test_terrains: list[int] = field(default_factory=lambda: [1000, 1001, 1002, 1003])
    # Terrains with an exhaustive table (the regret reference and the terrain criterion); must hold every test
    # terrain. Tables measured under the current settings are committed under measured/modular/exhaustive/.
    truth_terrains: list[int] = field(default_factory=lambda: [1000, 1001, 1002, 1003])
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
        missing = sorted(set(self.test_terrains) - set(self.truth_terrains))
        if missing:
            raise InputError(f"truth_terrains: expected every test terrain, missing {missing} (their exhaustive "
                             "tables are the regret reference)")
        outside = sorted(s for s in self.test_terrains if s not in TEST_SEED_BLOCK)
        if outside:
            raise InputError(f"test_terrains: expected seeds in [{TEST_SEED_BLOCK.start}, {TEST_SEED_BLOCK.stop}) "
                             f"(training draws terrains outside it), found {outside}")
        if self.generations < 1 or self.random_designs < 1:
            raise InputError("generations and random_designs: expected positive integers")


@dataclass(frozen=True)
class ModularParams:
    eval: EvalSettings = field(default_factory=EvalSettings)
    fitness: FitnessRule = field(default_factory=FitnessRule)
    experiments: ExperimentsConfig = field(default_factory=ExperimentsConfig)

    def __post_init__(self) -> None:
        check_physics(self.eval, "eval")
        check_course(self.eval, "eval")


def course_reach(settings: EvalSettings) -> float:
    """The farthest x any design can reach within the episode: the fastest speed for the episode's duration."""
    duration = settings.control_steps * settings.sim_steps_per_control * settings.time_step
    return FASTEST_SPEED * duration + FRONT_REACH


def check_course(settings: EvalSettings, where: str) -> None:
    """The course must be as long as the episode: no design may run past the last block before the episode ends."""
    reach, end = course_reach(settings), settings.terrain.x_range[1]
    if end < reach:
        raise InputError(f"{where}.terrain.x_range: the course ends at x = {end:g} m, but within the episode "
                         f"({settings.control_steps} control steps) the fastest design (wheels, "
                         f"{FASTEST_SPEED:.2f} m/s) reaches x = {reach:.2f} m; expected x_range[1] >= {reach:.2f} "
                         "or fewer control_steps")


# Physical settings of an episode and its terrain: field -> (lowest, highest, lowest allowed itself, unit).
# pybullet takes any float silently (a negative friction or time step runs and returns a distance), so they are
# checked where params are read, before any reaches a rollout or a cache key.
PHYSICAL_BOUNDS = {
    "time_step": (0.0, math.inf, False, "s per sim step"),
    "settle_steps": (0, math.inf, True, "sim steps"),
    "flip_up_z": (-1.0, 1.0, True, "the world z of the chassis' up axis"),
    "max_abs_y": (0.0, math.inf, False, "m"),
    "stall_distance": (0.0, math.inf, True, "m"),
    "terrain.x_range": (-math.inf, math.inf, False, "m"),
    "terrain.y_range": (-math.inf, math.inf, False, "m"),
    "terrain.clear_x": (0.0, math.inf, True, "m"),
    "terrain.side_range": (0.0, math.inf, False, "m"),
    "terrain.max_height_range": (0.0, math.inf, True, "m"),
    "terrain.friction": (0.0, math.inf, False, "pybullet's lateral friction coefficient"),
    "terrain.ground_friction": (0.0, math.inf, False, "pybullet's lateral friction coefficient"),
    "terrain.candidates": (1, math.inf, True, "candidates per point"),
}


def check_physics(settings: EvalSettings, where: str) -> None:
    """Every physical setting of `settings` finite and within PHYSICAL_BOUNDS; else InputError naming the field."""
    for name, (lowest, highest, closed, unit) in PHYSICAL_BOUNDS.items():
        owner = settings.terrain if name.startswith("terrain.") else settings
        value = getattr(owner, name.removeprefix("terrain."))
        if all(math.isfinite(v) and (lowest <= v if closed else lowest < v) and v <= highest
               for v in (value if isinstance(value, tuple) else (value,))):
            continue
        bounds = [f"{'>=' if closed else '>'} {lowest:g}"] if math.isfinite(lowest) else []
        bounds += [f"<= {highest:g}"] if math.isfinite(highest) else []
        noun, shown = ("finite numbers", list(value)) if isinstance(value, tuple) else ("a finite number", value)
        raise InputError(f"{where}.{name}: expected {' '.join([noun, ' and '.join(bounds)]).strip()} ({unit}), "
                         f"found {shown!r}")
