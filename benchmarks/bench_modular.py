"""Benchmark: modular-robot evaluations (pybullet rollouts of the tripod controller on a block terrain), at the
settings of the exhaustive tables (params.yaml `modular.eval`).

modular.overhead_ratio: wall time of a work item of STEPS_DESIGNS (terrain generated, one client, each design's
    world reset, built, settled and controlled) / the time inside its own stepSimulation calls (the raw physics
    it needs; MPPI's figure is defined the same way). Goal <= 1.3.
modular.idle_ratio: the same wall time / as many bare stepSimulation calls on the same terrain and robots with
    no control after the build. A robot holding its rest pose makes fewer and steadier contacts than one that
    walks (six leg-wheels: ~0.37 against ~0.67 ms per step), so this ratio also counts physics the idle robot
    does not do; it is an upper bound of the overhead.
modular.steps_per_s: sim steps per second of those rollouts (one process).
modular.evals_per_s: evaluations per second of a batch of BATCH valid designs through `evaluate_designs` (work
    items of `chunk_size` designs) on all cores, no cache.
modular.evals_per_s_speedup: that rate / the rate of the same batch fanned out as one design per item with its
    own client and terrain (the previous unit of work), alternated in the same run.
modular.parallel_speedup: the chunked batch's rate on all cores / in one process, same run.
"""

from __future__ import annotations

import time

import numpy as np
import pybullet as pb

from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.modular.evaluate import FitnessRule, evaluate_designs, simulate
from robocompose.modular.params import ModularParams
from robocompose.modular.robot import START_HEIGHT, all_designs, build_robot, valid_in_original
from robocompose.modular.terrain import add_terrain, generate_terrain
from robocompose.params import load_section
from robocompose.sim.physics import connect

SETTINGS = load_section(ModularParams, "modular").eval
TERRAIN = 1000
STEPS_DESIGNS = ("llllll", "wwwwww", "bbbbbb", "lwbllw")
BATCH = 48
ROUNDS = 3  # alternated rounds; the machine is shared, so each figure takes the best round


def _raw_seconds(design: str, steps: int) -> float:
    """Time of `steps` bare stepSimulation calls on the terrain and `design`, no control after the build."""
    client = connect(SETTINGS.physics())
    try:
        add_terrain(client, generate_terrain(TERRAIN, SETTINGS.terrain))
        build_robot(design, client, position=(0.0, 0.0, START_HEIGHT))
        started = time.perf_counter()
        for _ in range(steps):
            pb.stepSimulation(physicsClientId=client)
        return time.perf_counter() - started
    finally:
        pb.disconnect(physicsClientId=client)


def _overhead() -> tuple[float, float, float]:
    """(wall / its own stepping, wall / idle stepping, sim steps per second) of one work item."""
    step, inside = pb.stepSimulation, [0.0]

    def timed_step(*args, **kwargs):
        started = time.perf_counter()
        step(*args, **kwargs)
        inside[0] += time.perf_counter() - started

    pb.stepSimulation = timed_step  # the rollout calls pybullet.stepSimulation through the module
    try:
        started = time.perf_counter()
        rows = simulate([(design, TERRAIN, SETTINGS) for design in STEPS_DESIGNS])
        wall = time.perf_counter() - started
    finally:
        pb.stepSimulation = step
    raw = sum(_raw_seconds(design, row["sim_steps"]) for design, row in zip(STEPS_DESIGNS, rows, strict=True))
    steps = sum(row["sim_steps"] for row in rows)
    return wall / inside[0], wall / raw, steps / wall


def _per_design_rate(executor: Executor, batch: list[str]) -> float:
    started = time.perf_counter()
    executor.map(simulate, [[(design, TERRAIN, SETTINGS)] for design in batch])
    return len(batch) / (time.perf_counter() - started)


def _chunked_rate(executor: Executor, batch: list[str]) -> float:
    started = time.perf_counter()
    evaluate_designs(batch, TERRAIN, SETTINGS, FitnessRule(), EvaluationCache(), executor)
    return len(batch) / (time.perf_counter() - started)


def run() -> dict[str, float]:
    ratio, idle_ratio, steps_per_s = min(_overhead() for _ in range(ROUNDS))
    valid = [d for d in all_designs() if valid_in_original(d)]
    batch = [valid[i] for i in np.random.default_rng(0).choice(len(valid), BATCH, replace=False)]
    before = after = 0.0
    with Executor(workers=0) as executor:
        executor.map(simulate, [[(batch[0], TERRAIN, SETTINGS)]] * executor.workers)  # start the workers
        for round_ in range(ROUNDS):  # ABBA order against drift of the machine's load
            first, second = (_per_design_rate, _chunked_rate) if round_ % 2 == 0 else (_chunked_rate, _per_design_rate)
            rates = {first: first(executor, batch), second: second(executor, batch)}
            before, after = max(before, rates[_per_design_rate]), max(after, rates[_chunked_rate])
    with Executor(workers=1) as executor:
        one = _chunked_rate(executor, batch)
    return {"modular.overhead_ratio": ratio, "modular.idle_ratio": idle_ratio, "modular.steps_per_s": steps_per_s,
            "modular.evals_per_s": after, "modular.evals_per_s_speedup": after / before,
            "modular.parallel_speedup": after / one}


if __name__ == "__main__":
    print(run())
