"""Benchmark: the robot evaluator (MPPI in pybullet) against the raw physics it needs.

mppi.overhead_ratio: wall time of one MPPI episode / time spent inside its own `stepSimulation` calls
    (the raw physics steps it needs). Target <= 1.2: controller, sampling, reward and state restores
    cost at most 20 % on top of the physics.
mppi.replay_ratio: the same wall time / the same number of bare `stepSimulation` calls replaying the
    episode's applied targets from the start state. Noisy rollouts make more contacts than the smooth
    trajectory, so their steps cost more: this ratio is above the overhead ratio.
mppi.lockstep_vs_restore: time of an MPPI update with RoboGrammar's scheme (one client per sample, all
    stepped in lockstep with the applied input) / with ours (one client, restoreState per sample).
    > 1 means restoreState is faster; it is what `robocompose.control.mppi` uses.
mppi.us_per_sim_step: evaluator wall time per physics step (one core).
sim.steps_per_s: raw pybullet steps per second of RoboGrammar's flat design on flat (the replay above, one core).
evaluate.seconds_default: one default-profile evaluation of RoboGrammar's flat design on flat (one core).
evaluate.seconds_paper: the paper profile's step count times the measured time per step (extrapolated:
    a measured fraction of the paper's episode, not a full paper run).
"""

from __future__ import annotations

import time

import numpy as np
import pybullet as pb

from robocompose.control.mppi import MPPIConfig, rollout_return, run_episode, sample_inputs
from robocompose.control.world import RobotWorld
from robocompose.evaluation.evaluate import EvaluationConfig, evaluate
from robocompose.grammar.derivation import derive, parse_rules
from robocompose.grammar.references import REFERENCE_DESIGNS
from robocompose.params import load_section
from robocompose.tasks.terrains import get_task

SMALL = MPPIConfig(samples=16, first_samples=32, horizon=8, episode=16)


def _raw_seconds(tree, episode_inputs: np.ndarray, n_steps: int, interval: int) -> float:
    """Time of `n_steps` bare stepSimulation calls, cycling through the episode's joint targets."""
    with RobotWorld(tree, get_task("flat")) as world:
        start = world.save()
        client, body, hinges = world.client, world.body, world.hinges
        started = time.perf_counter()
        done = 0
        while done < n_steps:
            pb.restoreState(start, physicsClientId=client)
            for targets in episode_inputs:
                pb.setJointMotorControlArray(body, hinges, pb.POSITION_CONTROL, targetPositions=list(targets),
                                             physicsClientId=client)
                for _ in range(interval):
                    pb.stepSimulation(physicsClientId=client)
                done += interval
                if done >= n_steps:
                    break
        return time.perf_counter() - started


def _overhead(tree) -> tuple[float, float, float, float]:
    """(wall / time in stepSimulation, wall / replay time, wall microseconds per sim step) of one episode."""
    step, inside = pb.stepSimulation, [0.0]

    def timed_step(*args, **kwargs):
        started = time.perf_counter()
        step(*args, **kwargs)
        inside[0] += time.perf_counter() - started

    with RobotWorld(tree, get_task("flat")) as world:
        pb.stepSimulation = timed_step  # the world calls pybullet.stepSimulation through the module
        try:
            started = time.perf_counter()
            episode = run_episode(world, SMALL, seed=0)
            seconds, steps = time.perf_counter() - started, world.sim_steps
        finally:
            pb.stepSimulation = step
    replay = _raw_seconds(tree, episode.inputs, steps, SMALL.interval)
    return seconds / inside[0], seconds / replay, seconds / steps * 1e6, steps / replay


def _update_seconds_restore(tree, updates: int) -> float:
    with RobotWorld(tree, get_task("flat")) as world:
        plan = history = np.zeros((world.dof, SMALL.horizon))
        started = time.perf_counter()
        for u in range(updates):
            state = world.save()
            for k in range(SMALL.samples):
                world.restore(state)
                rollout_return(world, sample_inputs(plan, history, k, np.random.default_rng((0, u, k)), SMALL), SMALL)
            world.restore(state)
            world.forget(state)
            world.run(plan[:, 0], SMALL.interval)
        return time.perf_counter() - started


def _update_seconds_lockstep(tree, updates: int) -> float:
    """RoboGrammar's scheme: sample k rolls out in its own client, then every client steps the applied input."""
    worlds = [RobotWorld(tree, get_task("flat")) for _ in range(SMALL.samples)]
    try:
        plan = history = np.zeros((worlds[0].dof, SMALL.horizon))
        started = time.perf_counter()
        for u in range(updates):
            for k, world in enumerate(worlds):
                state = world.save()
                rollout_return(world, sample_inputs(plan, history, k, np.random.default_rng((0, u, k)), SMALL), SMALL)
                world.restore(state)
                world.forget(state)
            for world in worlds:
                world.run(plan[:, 0], SMALL.interval)
        return time.perf_counter() - started
    finally:
        for world in worlds:
            world.close()


def run() -> dict[str, float]:
    tree = derive(parse_rules(REFERENCE_DESIGNS["robogrammar_flat"])).tree
    ratio, replay_ratio, us_per_step, raw_steps_per_s = min(_overhead(tree) for _ in range(2))
    restore = lockstep = float("inf")
    for _ in range(4):  # alternated, best of four: the machine is shared
        restore = min(restore, _update_seconds_restore(tree, 6))
        lockstep = min(lockstep, _update_seconds_lockstep(tree, 6))
    default = load_section(EvaluationConfig, "evaluation")
    row = evaluate(tree, "flat", default, seed=0)
    paper_steps = MPPIConfig().sim_steps()
    return {"mppi.overhead_ratio": ratio, "mppi.replay_ratio": replay_ratio,
            "mppi.lockstep_vs_restore": lockstep / restore, "mppi.us_per_sim_step": us_per_step,
            "sim.steps_per_s": raw_steps_per_s, "evaluate.seconds_default": row["seconds"],
            "evaluate.seconds_paper": paper_steps * row["seconds"] / row["sim_steps"]}
