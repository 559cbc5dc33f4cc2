"""Evaluating a modular design on a block terrain: one pybullet rollout, the distance travelled in x.

Episode (thesis 5.1): the chassis starts at (0, 0, 0.3) in the rest pose and settles for `settle_steps` sim
steps; then `control_steps` control steps of `sim_steps_per_control` sim steps each (dt 1/240). The distance is
the chassis's x at the end minus its x when the episode starts. Early stops (the reference's): the robot flips
(the chassis's up axis has world z < 0.1), leaves the course (|y| > 2), or moves less than 0.02 m in the plane
over 25 control steps; the distance is then taken where it stopped.

Statuses: `ok` (ran to the end), `flipped`, `left_course`, `stalled` (early stops: the distance is real);
`unstable` (non-finite state or a blow-up: no distance); `invalid` (a design the original rejected, under
the `penalty` rule: not simulated, no distance). Optimisers turn a result into a fitness with
`FitnessRule.fitness`: the distance, or the penalty (-10, the original's score) when there is none.

Results are cached in the shared evaluation cache, key (design port string, "blocks-<seed>", settings hash,
seed 0): the rollout is deterministic, so the seed column is always 0. The settings hash covers the episode
settings, the terrain ranges, the physics (gravity, damping, solver), the controller's gait, and the code and
constants a rollout reaches (`robocompose.io.provenance.result_digest`).
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field

import numpy as np

from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor, evaluate_many
from robocompose.io.errors import InputError
from robocompose.io.provenance import result_digest, settings_digest
from robocompose.modular.controller import RobotState, make_controller
from robocompose.modular.robot import START_HEIGHT, ModularRobot, build_robot, parse_design, valid_in_original
from robocompose.modular.terrain import Terrain, TerrainConfig, add_terrain, generate_terrain

# Where a result's code starts: one rollout on a generated terrain (robot parts and masses, motor gains, gait,
# terrain grid, stops), and the rule of which designs the original rejects (they are scored, not simulated).
RESULT_CODE = ("robocompose.modular.evaluate:simulate", "robocompose.modular.robot:valid_in_original")
REWARD_STATUSES = ("ok", "flipped", "left_course", "stalled")  # statuses that carry a measured distance
BLOWUP_SPEED = 50.0  # m/s; a chassis faster than this has exploded


@dataclass(frozen=True)
class EvalSettings:
    """Everything a rollout depends on (all of it enters the settings hash)."""

    control_steps: int = 50  # the default profile (4.2 s); thesis and paper profile: 250 (~20.8 s)
    sim_steps_per_control: int = 20
    settle_steps: int = 100  # sim steps in the rest pose before the episode
    time_step: float = 1 / 240  # s
    solver_iterations: int = 50  # pybullet's default, written out
    flip_up_z: float = 0.1  # stop when the chassis up axis' world z drops below this
    max_abs_y: float = 2.0  # m, stop when the chassis leaves the course sideways
    stall_window: int = 25  # control steps
    stall_distance: float = 0.02  # m, stop when the chassis moved less than this over stall_window
    controller: str = "tripod"
    terrain: TerrainConfig = field(default_factory=TerrainConfig)

    def __post_init__(self):
        for name in ("control_steps", "sim_steps_per_control", "stall_window", "solver_iterations"):
            if getattr(self, name) < 1:
                raise InputError(f"{name}: expected a positive integer, found {getattr(self, name)}")
        make_controller(self.controller)  # fails early on an unknown name
        if isinstance(self.terrain, dict):  # from params.yaml
            object.__setattr__(self, "terrain", TerrainConfig(**self.terrain))

    def physics(self):
        from robocompose.sim.physics import PhysicsSettings

        return PhysicsSettings(time_step=self.time_step, solver_iterations=self.solver_iterations)

    def settings_hash(self) -> str:
        """16 hex digits of everything a rollout depends on besides design and terrain seed (see module doc)."""
        controller = make_controller(self.controller)
        return settings_digest({"settings": asdict(self), "physics": self.physics(),
                                "gait": getattr(controller, "gait", None), "controller": type(controller).__name__,
                                "code": result_digest(*RESULT_CODE)})

    @property
    def sim_steps(self) -> int:
        return self.settle_steps + self.control_steps * self.sim_steps_per_control


@dataclass(frozen=True)
class FitnessRule:
    """How results become the fitness optimisers maximise."""

    invalid: str = "penalty"  # "penalty": designs the original rejected score `penalty` unsimulated; "simulate"
    penalty: float = -10.0  # the original's score of an invalid design; also given to `unstable` results

    def __post_init__(self):
        if self.invalid not in ("penalty", "simulate"):
            raise InputError(f"invalid: expected 'penalty' or 'simulate', found {self.invalid!r}")

    def skips(self, design: str) -> bool:
        """True if `design` is scored without simulation."""
        return self.invalid == "penalty" and not valid_in_original(design)

    def fitness(self, result: Result) -> float:
        return self.penalty if result.distance is None else result.distance


@dataclass(frozen=True)
class Result:
    distance: float | None  # m travelled in x; None when the status carries no distance
    status: str
    sim_steps: int
    seconds: float


StepCallback = Callable[[float, ModularRobot], None]  # (time s, robot) after each control step (and at t=0)


def rollout(design: str, terrain: Terrain, settings: EvalSettings, visual: bool = False,
            on_step: StepCallback | None = None) -> Result:
    """Simulate `design` on `terrain` under `settings`' controller; see the module docstring for the episode."""
    return rollouts([design], terrain, settings, visual, on_step)[0]


def rollouts(designs: Sequence[str], terrain: Terrain, settings: EvalSettings, visual: bool = False,
             on_step: StepCallback | None = None) -> list[Result]:
    """Rollouts of `designs` on `terrain`, one after another in one pybullet client.

    Before each design the world is reset (resetSimulation, the physics settings, the terrain rebuilt), which
    gives a fresh client's bytes. Keeping the terrain and removing the last robot (removeBody) does not: one
    design in 30 moved 1.2 mm differently on terrain 1000. A result's `seconds` counts its own reset and episode.
    """
    import pybullet as pb

    from robocompose.sim.physics import configure

    client = pb.connect(pb.DIRECT)
    results = []
    try:
        for design in designs:
            started = time.perf_counter()
            configure(client, settings.physics())
            add_terrain(client, terrain, visual=visual)
            distance, status, steps = _episode(design, client, settings, visual, on_step)
            results.append(Result(distance, status, steps, time.perf_counter() - started))
    finally:
        pb.disconnect(physicsClientId=client)
    return results


def _episode(design: str, client: int, settings: EvalSettings, visual: bool,
             on_step: StepCallback | None) -> tuple[float | None, str, int]:
    """(distance, status, sim steps) of one episode of `design` in `client`, whose world holds only the terrain."""
    import pybullet as pb

    robot = build_robot(design, client, position=(0.0, 0.0, START_HEIGHT), visual=visual)
    controller = make_controller(settings.controller)
    controller.reset(robot)
    # Start in the pose the controller asks for first (wheels already steered, drives still), so the
    # episode does not begin with the modules fighting each other through a transient.
    sent = robot.pose(controller.act(_state(robot, 0.0)))
    for _ in range(settings.settle_steps):
        pb.stepSimulation(physicsClientId=client)
    x0 = _state(robot, 0.0).position[0]
    history = []  # (x, y) per control step
    status, steps = "ok", settings.settle_steps
    if on_step is not None:
        on_step(0.0, robot)
    control_dt = settings.sim_steps_per_control * settings.time_step
    state = _state(robot, 0.0)
    for step in range(settings.control_steps):
        sent = robot.command(controller.act(state), sent)
        for _ in range(settings.sim_steps_per_control):
            pb.stepSimulation(physicsClientId=client)
        steps += settings.sim_steps_per_control
        state = _state(robot, (step + 1) * control_dt)
        if on_step is not None:
            on_step(state.t, robot)
        status = _stop_reason(state, history, settings)
        if status != "ok":
            break
    return (None if status == "unstable" else float(state.position[0] - x0)), status, steps


def _state(robot: ModularRobot, t: float) -> RobotState:
    import pybullet as pb

    position, orientation = pb.getBasePositionAndOrientation(robot.body, physicsClientId=robot.client)
    linear, angular = pb.getBaseVelocity(robot.body, physicsClientId=robot.client)
    q, qd = robot.joint_state()
    return RobotState(t, np.array(position), np.array(orientation), np.array(linear), np.array(angular), q, qd)


def up_z(orientation: np.ndarray) -> float:
    """World z component of the body's z axis for a quaternion (x, y, z, w)."""
    x, y, _, _ = orientation
    return float(1.0 - 2.0 * (x * x + y * y))


def _stop_reason(state: RobotState, history: list, settings: EvalSettings) -> str:
    """'ok' to go on, or why the episode ends now; appends the chassis's (x, y) to `history`."""
    values = np.concatenate([state.position, state.orientation, state.linear_velocity, state.joint_positions])
    if not np.isfinite(values).all() or np.linalg.norm(state.linear_velocity) > BLOWUP_SPEED:
        return "unstable"
    if up_z(state.orientation) < settings.flip_up_z:
        return "flipped"
    if abs(state.position[1]) > settings.max_abs_y:
        return "left_course"
    history.append(state.position[:2].copy())
    if len(history) > settings.stall_window:
        moved = math.dist(history[-1], history[-1 - settings.stall_window])
        if moved < settings.stall_distance:
            return "stalled"
    return "ok"


# --- cached, batched evaluation ---

TASK_PREFIX = "blocks-"
SEED = 0  # the rollout is deterministic; the cache's seed column
CHUNK = 8  # designs per work item at most (see chunk_size)


def task_id(terrain_seed: int) -> str:
    return f"{TASK_PREFIX}{int(terrain_seed)}"


def simulate(jobs: Sequence[tuple[str, int, EvalSettings]]) -> list[dict]:
    """Rollouts of (design, terrain seed, settings) items as eval_cache rows: a batch sent to one worker, where one
    client and one terrain serve every design of the same terrain and settings."""
    rows = []
    for (terrain_seed, settings), group in itertools.groupby(jobs, key=lambda job: (job[1], job[2])):
        designs = [job[0] for job in group]
        rows += [{"reward": r.distance, "status": r.status, "sim_steps": r.sim_steps, "seconds": r.seconds}
                 for r in rollouts(designs, generate_terrain(terrain_seed, settings.terrain), settings)]
    return rows


def chunk_size(designs: int, workers: int) -> int:
    """Designs per work item: up to CHUNK, but at least 8 items per worker so the last ones balance."""
    return max(1, min(CHUNK, math.ceil(designs / (8 * workers))))


def evaluate_designs(designs: Sequence[str], terrain_seed: int, settings: EvalSettings, rule: FitnessRule,
                     cache: EvaluationCache | None = None, executor: Executor | None = None,
                     save_every: int = 0) -> list[Result]:
    """Results of `designs` on terrain `terrain_seed`, through the shared cache and executor.

    Cache hits are read; the distinct misses are simulated by `executor` (None: in this process) in work items
    of `chunk_size` designs and stored as they arrive (the cache is saved after every `save_every` or more new
    results, so a long batch resumes). Designs the rule skips are answered without simulating or caching.
    """
    designs = [parse_design(d) for d in designs]
    settings_hash = settings.settings_hash()
    cache = EvaluationCache() if cache is None else cache

    def key(job: tuple[str, int, EvalSettings]) -> tuple:
        return job[0], task_id(job[1]), settings_hash, SEED

    jobs = [(d, int(terrain_seed), settings) for d in designs if not rule.skips(d)]
    missing = len({key(job) for job in jobs} - {key(job) for job in jobs if key(job) in cache})
    size = chunk_size(missing, 1 if executor is None else executor.workers)
    rows = iter(evaluate_many(simulate, jobs, key, cache, executor, save_every, batch=size))
    skipped = Result(None, "invalid", 0, 0.0)
    return [skipped if rule.skips(d) else _from_row(next(rows)) for d in designs]


def _from_row(row: dict) -> Result:
    return Result(row["reward"], row["status"], int(row["sim_steps"]), float(row["seconds"]))
