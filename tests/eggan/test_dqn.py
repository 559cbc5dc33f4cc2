"""Whitman's DQN baseline: it learns the toy problem's task-dependent optimum, its search answers k distinct designs
in the problem's decision structure, its settings are checked, and a run is reproducible to the byte."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from robocompose.eggan.dqn import (
    DQNConfig,
    best_designs,
    boltzmann_episodes,
    choices_to_rows,
    load_dqn,
    save_dqn,
    train_dqn,
)
from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.problem import decision_groups_of
from robocompose.io.errors import ArtifactError, InputError
from robocompose.params import build_config

from .conftest import CHOICES, PORTS, MatchProblem

TINY = DQNConfig(iterations=6, tasks=2, episodes=4, updates=2, batch=8, start=8, replay=32, hidden=16, layers=1)
SMALL_NET = NetworkConfig(latent=8, filters=4)


class MirroredMatch(MatchProblem):
    """The toy problem decided one choice per mirrored pair of ports (as the modular robot's DQN is)."""

    name = "match-mirrored"
    decision_groups = ((0, 5), (1, 4), (2, 3))


def test_trained_greedy_policy_finds_the_optimum_far_more_often_than_random(match_problem):
    config = DQNConfig(iterations=100, tasks=8, episodes=8, updates=16, batch=64, start=128, hidden=128, layers=2,
                       target_every=10, lr=3e-3, temperature_decay=1000.0, temperature_end=0.5)
    net, rows = train_dqn(match_problem, NetworkConfig(latent=32, filters=32), config)
    rng = np.random.default_rng(999)  # held-out tasks: not the training streams
    matches, optimum_found = [], 0
    for _ in range(50):
        task = match_problem.sample_task(rng)
        answers = best_designs(net, match_problem, task, 10)
        matches.append(sum(a == b for a, b in zip(answers[0][0], task, strict=True)))
        optimum_found += any(design == task for design, _ in answers)
    # random: 1.5 of 6 ports match; 10 random designs hold the optimum with probability 10 / 4^6 = 0.0024
    assert np.mean(matches) > 3.0
    assert optimum_found / 50 > 0.2
    assert rows[-1]["td_loss"] < rows[1]["td_loss"]
    assert rows[-1]["episodes"] == 100 * 64 and rows[-1]["updates"] == (100 - 1) * 16  # learning starts at 128


def test_best_designs_are_distinct_greedy_first_and_follow_the_decision_groups():
    problem = MirroredMatch()
    net, _ = train_dqn(problem, SMALL_NET, TINY)
    task = problem.sample_task(np.random.default_rng(3))
    everything = best_designs(net, problem, task, 100)  # more than the 4^3 symmetric designs: the whole tree
    designs = [design for design, _ in everything]
    assert len(designs) == CHOICES ** 3 == len(set(designs))
    assert all(design == design[::-1] for design in designs)  # one choice per mirrored pair
    # the first answer is the greedy design: Boltzmann exploration at a vanishing temperature plays it
    greedy = boltzmann_episodes(net, problem.encode_task(task).unsqueeze(0), 1e-9, torch.Generator().manual_seed(0))
    assert [designs[0]] == problem.designs_from_choices(choices_to_rows(greedy.numpy(), problem.decision_groups))
    assert best_designs(net, problem, task, 5) == everything[:5]


def test_decisions_fill_their_groups_and_bad_groups_fail():
    assert choices_to_rows(np.array([[1, 2, 3]]), MirroredMatch.decision_groups).tolist() == [[1, 2, 3, 3, 2, 1]]
    assert decision_groups_of(MatchProblem()) == tuple((r,) for r in range(PORTS))  # no groups: one row per step
    bad = MirroredMatch()
    bad.decision_groups = ((0, 5), (1, 4), (2,))
    with pytest.raises(ValueError, match="partition"):
        train_dqn(bad, SMALL_NET, TINY)


def test_config_errors_name_the_field():
    with pytest.raises(InputError, match="^iterations: expected a positive integer"):
        DQNConfig(iterations=0)
    with pytest.raises(InputError, match="temperature_start: expected >= temperature_end"):
        DQNConfig(temperature_start=1.0, temperature_end=2.0)
    with pytest.raises(InputError, match="start: expected <= replay"):
        DQNConfig(start=300, replay=200)
    with pytest.raises(InputError, match=r"^eggan_modular\.baselines\.dqn\.lr: expected a positive number"):
        build_config(DQNConfig, {"lr": 0.0}, "eggan_modular.baselines.dqn")
    with pytest.raises(InputError, match=r"eggan_modular\.baselines\.dqn\.epsilon: unknown field"):
        build_config(DQNConfig, {"epsilon": 0.1}, "eggan_modular.baselines.dqn")


def test_boltzmann_temperature_decays_to_its_floor():
    config = DQNConfig(temperature_start=10.0, temperature_end=2.0, temperature_decay=100.0)
    assert config.temperature(0) == 10.0
    assert config.temperature(100) == pytest.approx(10.0 / np.e)
    assert config.temperature(10_000) == 2.0


def test_same_config_same_model_bytes_and_the_file_round_trips(tmp_path):
    paths, nets = [], []
    for run, seed in enumerate((0, 0, 1)):
        problem = MirroredMatch()
        net, rows = train_dqn(problem, SMALL_NET, dataclasses.replace(TINY, seed=seed))
        paths.append(save_dqn(net, problem, tmp_path / f"run{run}.pt", {"final": rows[-1]}))
        nets.append(net)
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert paths[0].read_bytes() != paths[2].read_bytes()
    loaded, info = load_dqn(paths[0], problem)
    assert info["decision_groups"] == [[0, 5], [1, 4], [2, 3]] and info["hidden"] == TINY.hidden
    task = problem.sample_task(np.random.default_rng(5))
    assert best_designs(loaded, problem, task, 64) == best_designs(nets[0], problem, task, 64)
    with pytest.raises(InputError, match="not for match"):
        load_dqn(paths[0], MatchProblem())  # other decisions (one per port): refused
    cut = tmp_path / "cut.pt"
    cut.write_bytes(paths[0].read_bytes()[:-10])
    with pytest.raises(ArtifactError, match="cut.pt"):
        load_dqn(cut, problem)
    with pytest.raises(InputError, match="no such file"):
        load_dqn(tmp_path / "missing.pt", problem)
