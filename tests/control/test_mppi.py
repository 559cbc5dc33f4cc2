import math

import numpy as np
import pytest

from robocompose.control.mppi import NOISE_FILTER, MPPIConfig, run_episode, sample_inputs

TINY = MPPIConfig(samples=16, first_samples=32, horizon=4, episode=12, interval=4)


class PointSim:
    """A toy world: each coordinate follows its target (first order); reward -(x - 1)^2 summed per step."""

    def __init__(self, dof: int = 2, blow_up_after: int | None = None):
        self.dof, self.x, self.states, self.sim_steps = dof, np.zeros(dof), {}, 0
        self.blow_up_after = blow_up_after

    def run(self, targets, steps: int) -> float:
        total = 0.0
        for _ in range(steps):
            self.x = self.x + 0.2 * (np.asarray(targets) - self.x)
            total += -float(np.sum((self.x - 1.0) ** 2))
            self.sim_steps += 1
        if self.blow_up_after is not None and self.sim_steps > self.blow_up_after:
            return math.nan
        return total

    def save(self) -> int:
        self.states[len(self.states)] = self.x.copy()
        return len(self.states) - 1

    def restore(self, state: int) -> None:
        self.x = self.states[state].copy()

    def forget(self, state: int) -> None:
        del self.states[state]


def test_mppi_drives_the_toy_world_to_its_target():
    sim = PointSim()
    episode = run_episode(sim, TINY, seed=0)
    assert episode.control_steps == 12 and episode.inputs.shape == (12, 2)
    # Zero input would score -2 per step; the plan climbs towards the target step after step.
    assert episode.step_rewards[-3:].mean() > -0.6 > episode.step_rewards[0]
    assert episode.mean_reward == pytest.approx(episode.step_rewards.mean())
    rollouts = (TINY.first_samples + TINY.episode * TINY.samples) * TINY.horizon * TINY.interval
    assert sim.sim_steps == rollouts + TINY.episode * TINY.interval == TINY.sim_steps()
    assert sim.states == {}  # every saved state was released


def test_episode_is_deterministic_given_the_seed():
    a, b, c = (run_episode(PointSim(), TINY, seed=s) for s in (3, 3, 4))
    np.testing.assert_array_equal(a.inputs, b.inputs)
    assert not np.array_equal(a.inputs, c.inputs)


def test_a_blow_up_ends_the_episode_with_a_nan_reward():
    per_step = (TINY.samples * TINY.horizon + 1) * TINY.interval
    sim = PointSim(blow_up_after=TINY.first_samples * TINY.horizon * TINY.interval + 3 * per_step)
    episode = run_episode(sim, TINY, seed=0)
    assert math.isnan(episode.mean_reward) and episode.control_steps < TINY.episode


def test_warm_start_samples_are_the_plan_plus_smoothed_noise():
    plan = np.full((4000, 8), 0.3)
    sample = sample_inputs(plan, np.zeros_like(plan), k=1, rng=np.random.default_rng(0), config=MPPIConfig())
    noise = sample - plan
    assert noise.std() == pytest.approx(0.25 * np.linalg.norm(NOISE_FILTER), rel=0.02)
    neighbours = np.corrcoef(noise[:, :-1].ravel(), noise[:, 1:].ravel())[0, 1]
    assert neighbours > 0.5  # low-passed: consecutive columns are strongly correlated


def test_history_samples_replay_the_last_inputs_periodically_blended_in():
    history = np.arange(1.0, 5.0)[None, :]  # (1, H=4): inputs 1, 2, 3, 4, oldest first
    config = MPPIConfig(history_sigma=0.0)
    # k=0: period (0 mod 2) + 2 + 1 = 3 replays the last three inputs [2, 3, 4, 2], blended in with t=(j+1)/4.
    sample = sample_inputs(np.zeros((1, 4)), history, k=0, rng=np.random.default_rng(0), config=config)
    np.testing.assert_allclose(sample[0], [0.25 * 2, 0.5 * 3, 0.75 * 4, 1.0 * 2])
    # k=2: period 4 replays the whole history.
    sample = sample_inputs(np.zeros((1, 4)), history, k=2, rng=np.random.default_rng(0), config=config)
    np.testing.assert_allclose(sample[0], [0.25, 1.0, 2.25, 4.0])


def test_config_is_validated():
    with pytest.raises(ValueError, match="horizon: expected an integer >= 2"):
        MPPIConfig(horizon=1)
    with pytest.raises(ValueError, match="samples: expected an integer >= 1"):
        MPPIConfig(samples=0)


@pytest.mark.parametrize(("field", "value", "message"), [
    ("temperature", float("nan"), "temperature: expected a finite number > 0, found nan"),
    ("temperature", float("inf"), "temperature: expected a finite number > 0, found inf"),
    ("temperature", -1.0, "temperature: expected a finite number > 0, found -1.0"),
    ("temperature", 0.0, "temperature: expected a finite number > 0, found 0.0"),
    ("warm_start_sigma", float("nan"), "warm_start_sigma: expected a finite number >= 0, found nan"),
    ("history_sigma", float("-inf"), "history_sigma: expected a finite number >= 0, found -inf"),
    ("discount", float("nan"), "discount: expected a finite number in (0, 1], found nan"),
])
def test_a_float_setting_with_no_right_answer_is_refused(field, value, message):
    with pytest.raises(ValueError) as error:
        MPPIConfig(**{field: value})
    assert str(error.value) == message
