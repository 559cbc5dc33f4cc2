"""The EG-GAN experiments glue for Whitman's DQN: its decisions are the robot's mirrored port pairs, the baseline
trains on the shared problem and budget, and its proposer answers 10 distinct symmetric designs.

Rollouts are faked (distance = number of wheels minus terrain seed mod 3) so these tests check the glue; the DQN's
learning is tested on a toy problem in tests/eggan/test_dqn.py.
"""

from __future__ import annotations

import json

import pytest

from robocompose.eggan.dqn import load_dqn
from robocompose.modular import eggan_problem
from robocompose.modular.eggan_experiments import dqn_proposer, make_problem, train_dqn_baseline
from robocompose.modular.eggan_params import build_eggan_modular_params
from robocompose.modular.evaluate import EvalSettings, FitnessRule, Result
from robocompose.modular.params import ExperimentsConfig, ModularParams
from robocompose.modular.robot import PORT_XY

MODULAR = ModularParams(EvalSettings(control_steps=10), FitnessRule(), ExperimentsConfig())
PARAMS = build_eggan_modular_params({
    "fitness": {"train_terrains": 6, "warmup": 20, "warmup_terrains": 4, "budget": 40, "real_per_round": 4,
                "surrogate": {"steps": 20, "hidden": 16}},
    "network": {"latent": 8, "filters": 4},
    "baselines": {"dqn": {"iterations": 6, "tasks": 2, "episodes": 4, "updates": 2, "batch": 8, "start": 8,
                          "replay": 32, "hidden": 16, "layers": 1}}}, "test")


@pytest.fixture
def fake_rollouts(monkeypatch):
    calls = []

    def fake(designs, terrain_seed, settings, rule, cache=None, executor=None, save_every=0):
        calls.append(list(designs))
        return [Result(None, "invalid", 0, 0.0) if rule.skips(d) else Result(float(d.count("w")) - terrain_seed % 3,
                                                                                "ok", 10, 0.01) for d in designs]

    monkeypatch.setattr(eggan_problem, "evaluate_designs", fake)
    return calls


def test_decision_groups_are_the_mirrored_port_pairs():
    for left, right in eggan_problem.ModularEgganProblem.decision_groups:
        assert PORT_XY[left][0] == PORT_XY[right][0] and PORT_XY[left][1] == -PORT_XY[right][1]


def test_dqn_baseline_spends_the_budget_and_proposes_ten_distinct_symmetric_designs(tmp_path, fake_rollouts):
    metrics = train_dqn_baseline(MODULAR, PARAMS, None, None, tmp_path)
    assert metrics["method"] == "DQN" and metrics["episodes"] == 6 * 2 * 4
    assert metrics["real_evaluations"] == sum(len(c) for c in fake_rollouts) > PARAMS.fitness.warmup  # real rounds ran
    saved = json.loads((tmp_path / "eggan_modular_dqn.json").read_text())
    assert saved["decision_groups"] == [[0, 5], [1, 4], [2, 3]] and "train_seconds" not in saved["metrics"]
    problem = make_problem(MODULAR, PARAMS, None, None)
    propose = dqn_proposer(load_dqn(tmp_path / "eggan_modular_dqn.pt", problem)[0])
    answer = propose(problem, 1000, query_seed=7, candidates=10)
    assert len(answer) == len(set(answer)) == 10
    assert all(design == design[::-1] for design in answer)  # port order runs around the rim: mirrored = reversed
    assert propose(problem, 1000, query_seed=8, candidates=10) == answer  # the greedy search has no randomness
