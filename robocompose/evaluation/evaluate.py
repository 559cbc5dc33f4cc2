"""The robot evaluator: a design's score on a task is the mean reward of one MPPI episode in pybullet.

    from robocompose.evaluation.evaluate import EvaluationConfig, evaluate
    row = evaluate(tree, "flat", EvaluationConfig(), seed=0)
    # {"reward": 4.57, "status": "ok", "sim_steps": 107264, "seconds": 8.8}   (an `eval_cache` row's values)

Many designs, cached and fanned out (`robocompose.fanout`: local processes or a Dask cluster):
    rows = evaluate_designs(trees, ["flat", "wall"], config, seeds=[0], cache=cache, executor=executor)
    row = cached_evaluations([EvalJob(tree, "flat", config, seed=0)], cache)[0]   # a dict, key columns too

Status of a result (`reward` is null unless noted):
- "ok": the episode ran; `reward` is its mean per-step reward (~4 standing still, +2 per m/s forward).
- "self_collision": the design self-penetrates when placed at rest (RoboGrammar rejects it); not simulated.
- "unstable": the simulation blew up: a non-finite state, or a mean reward >= 10 (`BLOWUP_REWARD`, the
  reference treats any such result as a blow-up); `reward` holds the measured value when finite.
Optimisers score a result with `objective(row, invalid)`: the reward when ok, else the method's invalid score,
by default `INVALID_SCORE[status]` (GLSO's 3.8 for a self-collision, 4.0 for a blow-up: about what a robot
standing still scores); RoboGrammar's searches score any invalid result `ROBOGRAMMAR_INVALID_SCORE` (-2.0).

The settings hash of a task covers everything that shapes a result besides design and seed: the MPPI
config, the physics settings, the task (floor, friction, horizon scale, obstacle seed), and the code and
constants the episode reaches (`robocompose.io.provenance.result_digest`), so a change of that code invalidates
the cache with no version to bump by hand, while moving it or editing messages does not.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field

import pandas as pd

from robocompose.control.mppi import MPPIConfig, run_episode
from robocompose.fanout.cache import EVAL_KEY_COLUMNS, EvaluationCache
from robocompose.fanout.executor import Executor, evaluate_many
from robocompose.grammar.tree import DesignTree
from robocompose.io import get_schema
from robocompose.io.errors import check_field
from robocompose.io.provenance import result_digest, settings_digest
from robocompose.sim.physics import PhysicsSettings
from robocompose.tasks.terrains import get_task

# Where a result's code starts: the episode, and through it the robot builder, terrains, reward and controller.
RESULT_CODE = ("robocompose.evaluation.evaluate:evaluate",)
OK, SELF_COLLISION, UNSTABLE = "ok", "self_collision", "unstable"
STATUSES = (OK, SELF_COLLISION, UNSTABLE)
BLOWUP_REWARD = 10.0  # any mean reward at or above this is a simulation blow-up
INVALID_SCORE = {SELF_COLLISION: 3.8, UNSTABLE: 4.0}  # what optimisers use instead of an invalid result (GLSO)
ROBOGRAMMAR_INVALID_SCORE = {SELF_COLLISION: -2.0, UNSTABLE: -2.0}  # heuristic_search_algo_mpc.py: None or > 10


@dataclass(frozen=True)
class EvaluationConfig:
    """The `evaluation:` section of params.yaml."""

    mppi: MPPIConfig = field(default_factory=MPPIConfig)  # controller settings (paper values by default)
    seed: int = 0  # controller seed of an evaluation (results are reproducible given design, task, seed)

    def __post_init__(self) -> None:
        check_field(self.seed >= 0, "seed", "an integer >= 0 (a controller seed)", self.seed)

    def settings_hash(self, task: str) -> str:
        """16 hex digits identifying everything that changes a result on `task` besides design and seed."""
        return settings_digest({"simulation": simulation_digest(task), "mppi": self.mppi.as_dict()})


def simulation_digest(task: str) -> str:
    """16 hex digits of what shapes a result on `task` besides the controller settings, design and seed: the
    task, the physics, and the code and constants the episode runs (`result_digest`)."""
    return settings_digest({"task": get_task(task), "physics": PhysicsSettings(), "code": result_digest(*RESULT_CODE)})


def objective(row: dict, invalid: dict[str, float] = INVALID_SCORE) -> float:
    """The number an optimiser maximises for an evaluation row: its reward if ok, else `invalid[status]`."""
    return float(row["reward"]) if row["status"] == OK else invalid[row["status"]]


def evaluate(tree: DesignTree, task: str, config: EvaluationConfig, seed: int,
             observer: Callable | None = None, visual: bool = False) -> dict:
    """Run one MPPI episode of `tree` on `task`; the values of an `eval_cache` row.

    `observer(world, step, reward)` is called after each control step (for logs and pictures).
    """
    from robocompose.control.world import RobotWorld

    started = time.perf_counter()
    spec = get_task(task)
    with RobotWorld(tree, spec, visual=visual) as world:
        if world.robot.self_penetrating:
            return {"reward": None, "status": SELF_COLLISION, "sim_steps": 0,
                    "seconds": time.perf_counter() - started}
        watch = None if observer is None else (lambda step, reward: observer(world, step, reward))
        episode = run_episode(world, config.mppi, seed, config.mppi.horizon * spec.horizon_scale, watch)
        reward = episode.mean_reward
        status = OK if math.isfinite(reward) and reward < BLOWUP_REWARD else UNSTABLE
        return {"reward": reward if math.isfinite(reward) else None, "status": status,
                "sim_steps": world.sim_steps, "seconds": time.perf_counter() - started}


@dataclass(frozen=True)
class EvalJob:
    """One evaluation as a picklable work item for an `Executor`."""

    tree: DesignTree
    task: str
    config: EvaluationConfig
    seed: int

    def key(self, settings_hash: str) -> tuple[str, str, str, int]:
        return (self.tree.design_id, self.task, settings_hash, self.seed)


def run_job(job: EvalJob) -> dict:
    return evaluate(job.tree, job.task, job.config, job.seed)


def cached_evaluations(jobs: Sequence[EvalJob], cache: EvaluationCache | None = None,
                       executor: Executor | None = None, save_every: int = 0) -> list[dict]:
    """The full `eval_cache` row (key and values) of every job, evaluating only the keys not cached."""
    hashes = {(job.task, job.config): job.config.settings_hash(job.task) for job in jobs}

    def key(job: EvalJob) -> tuple[str, str, str, int]:
        return job.key(hashes[job.task, job.config])

    rows = evaluate_many(run_job, jobs, key, cache=cache, executor=executor, save_every=save_every)
    return [{**dict(zip(EVAL_KEY_COLUMNS, key(job), strict=True)), **row} for job, row in zip(jobs, rows, strict=True)]


def evaluate_designs(trees: Sequence[DesignTree], tasks: Iterable[str], config: EvaluationConfig,
                     seeds: Iterable[int] = (0,), cache: EvaluationCache | None = None,
                     executor: Executor | None = None, save_every: int = 0) -> pd.DataFrame:
    """Every design on every task with every seed, through the cache: one `eval_cache` row each
    (design-major order)."""
    tasks, seeds = [get_task(t).name for t in tasks], list(seeds)
    jobs = [EvalJob(tree, task, config, seed) for tree in trees for task in tasks for seed in seeds]
    return pd.DataFrame(cached_evaluations(jobs, cache, executor, save_every), columns=get_schema("eval_cache").names)
