"""RoboGrammar's MPPI controller: plan joint-position targets by sampling rollouts from the current state.

Every control step (16 sim steps, 15 Hz) the controller
  1. saves the simulator state and runs `samples` rollouts of `horizon` control steps from it, each with
     an input sequence sampled around the current plan (below), scoring each by its discounted return
     R_k = sum_j discount^j * (sum of the per-sim-step rewards of control step j);
  2. sets the plan to the average of the sampled sequences weighted by exp(temperature * (R_k - max R));
  3. restores the state, applies the plan's first column for one control step (the episode's trajectory),
     appends it to the input history, shifts the plan left and zero-fills its last column.
The very first control step is preceded by one extra update with `first_samples` samples.

Sampling (RoboGrammar's DefaultInputSampler): even-indexed samples replay the last `repeat` columns of
the input history periodically, repeat = (k/2) mod (H/2) + H/2 + 1, blended linearly into the plan over
the horizon (weight (j+1)/H on the replay), with noise sigma 0.05; odd samples are the plan plus noise
sigma 0.25. Noise is white Gaussian smoothed by a 5-tap FIR low-pass (passband < 2 Hz at 15 Hz). Sample
k of the update that has drawn `n` samples before it uses the random stream (seed, n + k), so an episode
is a deterministic function of the design, the task, the config and the seed.

Rollouts run in the one simulator client, rewound with saveState/restoreState: measured faster than
RoboGrammar's one-client-per-sample stepped in lockstep (see benchmarks/bench_evaluate.py). A rollout
that becomes non-finite gets weight 0; a non-finite episode step ends the episode (status "unstable").

Cost of one episode in sim steps (`MPPIConfig.sim_steps`): (first_samples + episode * samples) * horizon
* interval for the rollouts, plus episode * interval for the trajectory itself.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Protocol

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from robocompose.io.errors import check_field, check_finite_fields, check_number

# 5-tap FIR low-pass applied to the sampling noise along time.
NOISE_FILTER = np.array([0.10422766377112629, 0.3239870556899027, 0.3658903830367387,
                         0.3239870556899027, 0.10422766377112629])


@dataclass(frozen=True)
class MPPIConfig:
    """MPPI settings; defaults are RoboGrammar's (the thesis's), the default profile cuts them."""

    samples: int = 64  # rollouts per update
    first_samples: int = 512  # rollouts of the extra update before the first control step
    horizon: int = 16  # control steps planned ahead (a task may ask for more: wall 32)
    episode: int = 128  # control steps per episode (128 x 16 = 2048 sim steps, 8.5 s)
    interval: int = 16  # sim steps per control step
    discount: float = 0.99  # per control step
    temperature: float = 1.0  # kappa in exp(kappa * (R_k - max R))
    history_sigma: float = 0.05  # noise of the history-replay samples (rad)
    warm_start_sigma: float = 0.25  # noise of the warm-start samples (rad)

    def __post_init__(self) -> None:
        for name in ("samples", "first_samples", "episode", "interval"):
            check_field(getattr(self, name) >= 1, name, "an integer >= 1", getattr(self, name))
        check_field(self.horizon >= 2, "horizon", "an integer >= 2 (control steps)", self.horizon)
        check_number(self.discount, "discount", 0.0, 1.0, "(]")
        check_number(self.temperature, "temperature", 0.0, bounds="()")  # kappa: 0 or less ranks nothing
        check_number(self.history_sigma, "history_sigma", 0.0)
        check_number(self.warm_start_sigma, "warm_start_sigma", 0.0)
        check_finite_fields(self)

    def as_dict(self) -> dict:
        return asdict(self)

    def sim_steps(self, horizon: int | None = None) -> int:
        """Physics steps of one episode of a robot with joints (rollouts and trajectory)."""
        rollouts = (self.first_samples + self.episode * self.samples) * (horizon or self.horizon)
        return (rollouts + self.episode) * self.interval


class Simulator(Protocol):
    """What MPPI needs from a world (see `robocompose.control.world.RobotWorld`)."""

    dof: int

    def run(self, targets, steps: int) -> float: ...  # sum of per-step rewards, NaN if non-finite
    def save(self) -> int: ...
    def restore(self, state: int) -> None: ...
    def forget(self, state: int) -> None: ...


@dataclass(frozen=True)
class Episode:
    """The result of one MPPI episode."""

    mean_reward: float  # mean per-sim-step reward of the trajectory (NaN if it became non-finite)
    control_steps: int  # control steps completed
    inputs: np.ndarray  # (T, dof) joint targets applied at each completed control step
    step_rewards: np.ndarray  # (T,) mean per-sim-step reward of each completed control step


def sample_inputs(plan: np.ndarray, history: np.ndarray, k: int, rng: np.random.Generator,
                  config: MPPIConfig) -> np.ndarray:
    """Input sequence (dof, H) of sample k around `plan` (dof, H), given the `history` (dof, H)."""
    dof, horizon = plan.shape
    if k % 2 == 0:
        repeat = (k // 2) % (horizon // 2) + horizon // 2 + 1
        replay = history[:, horizon - repeat:][:, np.arange(horizon) % repeat]  # (dof, H), period `repeat`
        blend = np.arange(1, horizon + 1) / horizon  # (H,) ramps the replay in, avoiding a jump
        base, sigma = blend * replay + (1.0 - blend) * plan, config.history_sigma
    else:
        base, sigma = plan, config.warm_start_sigma
    noise = rng.normal(0.0, sigma, (dof, horizon + len(NOISE_FILTER) - 1))  # (dof, H + 4)
    return base + sliding_window_view(noise, len(NOISE_FILTER), axis=1) @ NOISE_FILTER  # (dof, H)


def rollout_return(sim: Simulator, inputs: np.ndarray, config: MPPIConfig) -> float:
    """Discounted return of applying `inputs` (dof, H) from the current state; -inf if non-finite."""
    total, weight = 0.0, 1.0
    for column in inputs.T:
        reward = sim.run(column, config.interval)
        if not math.isfinite(reward):
            return -math.inf
        total += weight * reward
        weight *= config.discount
    return total


def update(sim: Simulator, plan: np.ndarray, history: np.ndarray, n_samples: int, seed: int, drawn: int,
           config: MPPIConfig) -> np.ndarray:
    """One MPPI update from the simulator's current state (left unchanged); returns the new plan."""
    state = sim.save()
    sequences = np.empty((n_samples, *plan.shape))  # (K, dof, H)
    returns = np.empty(n_samples)  # (K,)
    for k in range(n_samples):
        sequences[k] = sample_inputs(plan, history, k, np.random.default_rng((seed, drawn + k)), config)
        if k:
            sim.restore(state)
        returns[k] = rollout_return(sim, sequences[k], config)
    sim.restore(state)
    sim.forget(state)
    if not np.isfinite(returns).any():
        return plan  # every rollout blew up: keep the plan, the trajectory step will tell
    weights = np.exp(config.temperature * (returns - returns.max()))  # (K,); 0 for -inf returns
    return np.tensordot(weights, sequences, axes=1) / weights.sum()


def run_episode(sim: Simulator, config: MPPIConfig, seed: int, horizon: int | None = None,
                observer: Callable[[int, float], None] | None = None) -> Episode:
    """Control `sim` for `config.episode` control steps; `observer(step, reward)` after each one."""
    horizon = horizon or config.horizon
    plan = np.zeros((sim.dof, horizon))  # (dof, H)
    history = np.zeros((sim.dof, horizon))  # (dof, H) last applied targets, oldest first
    inputs, step_rewards, drawn = [], [], 0
    if sim.dof:
        plan = update(sim, plan, history, config.first_samples, seed, drawn, config)
        drawn += config.first_samples
    for step in range(config.episode):
        if sim.dof:
            plan = update(sim, plan, history, config.samples, seed, drawn, config)
            drawn += config.samples
        applied = plan[:, 0].copy()
        reward = sim.run(applied, config.interval) / config.interval
        if not math.isfinite(reward):
            return Episode(math.nan, step, np.array(inputs).reshape(-1, sim.dof), np.array(step_rewards))
        inputs.append(applied)
        step_rewards.append(reward)
        if observer is not None:
            observer(step, reward)
        history = np.roll(history, -1, axis=1)
        history[:, -1] = applied
        plan = np.roll(plan, -1, axis=1)
        plan[:, -1] = 0.0
    rewards = np.array(step_rewards)
    # (episode, dof); reshape by length, not -1, so a robot without hinges (dof 0) works too
    return Episode(float(rewards.mean()), config.episode, np.array(inputs).reshape(len(inputs), sim.dof), rewards)
