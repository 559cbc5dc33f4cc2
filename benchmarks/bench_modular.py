"""Benchmark: modular-robot evaluations (pybullet rollouts of the tripod controller on a block terrain).

modular.steps_per_s: sim steps per second of whole rollouts (build, settle, control, early stops) in one process,
    over STEPS_DESIGNS, under the default profile's settings (100 control steps).
modular.evals_per_s: evaluations per second of a batch of BATCH valid designs fanned out over all cores by the
    shared executor (no cache).
modular.parallel_speedup: the same batch's evaluations per second on all cores / in one process, same run.
"""

from __future__ import annotations

import time

import numpy as np

from robocompose.fanout.executor import Executor
from robocompose.modular.evaluate import EvalSettings, rollout, simulate
from robocompose.modular.robot import all_designs, valid_in_original
from robocompose.modular.terrain import generate_terrain

SETTINGS = EvalSettings(control_steps=100)  # the default profile's episode
TERRAIN = 1000
STEPS_DESIGNS = ("llllll", "wwwwww", "bbbbbb", "lwbllw")
BATCH = 12


def run() -> dict[str, float]:
    terrain = generate_terrain(TERRAIN, SETTINGS.terrain)
    steps = seconds = 0.0
    for design in STEPS_DESIGNS:
        result = rollout(design, terrain, SETTINGS)
        steps, seconds = steps + result.sim_steps, seconds + result.seconds
    valid = [d for d in all_designs() if valid_in_original(d)]
    batch = [valid[i] for i in np.random.default_rng(0).choice(len(valid), BATCH, replace=False)]
    jobs = [(d, TERRAIN, SETTINGS) for d in batch]
    rates = {}
    for workers in (1, 0):
        with Executor(workers=workers) as executor:
            executor.map(simulate, jobs[:1])  # start the workers before timing
            started = time.perf_counter()
            executor.map(simulate, jobs)
            rates[workers] = BATCH / (time.perf_counter() - started)
    return {"modular.steps_per_s": steps / seconds, "modular.evals_per_s": rates[0],
            "modular.parallel_speedup": rates[0] / rates[1]}


if __name__ == "__main__":
    print(run())
