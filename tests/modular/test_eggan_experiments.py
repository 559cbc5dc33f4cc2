"""The learned baselines in the modular experiments: MolGAN and Whitman's DQN train on the shared problem and
budget, are saved with their metrics (no wall times), and answer the real-time protocol with the protocol's
number of distinct candidates; the DQN decides one module per mirrored port pair. The protocol answers every
candidate from the test terrains' exhaustive tables, with the portfolio and the exhaustive optimum as rows.

Rollouts are faked (distance = the number of wheels minus the terrain seed mod 3), as in test_eggan_problem.py;
the DQN's learning is tested on a toy problem in tests/eggan/test_dqn.py.
"""

from __future__ import annotations

import json

import pandas as pd
import pytest

from robocompose.eggan.dqn import load_dqn
from robocompose.eggan.learners import dqn_answer
from robocompose.io.errors import InputError
from robocompose.modular import eggan_problem
from robocompose.modular.eggan_experiments import (
    REALTIME_METHODS,
    make_problem,
    method_title,
    random_proposer,
    realtime_proposers,
    realtime_table,
    table_proposers,
    train_baseline,
)
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.evaluate import EvalSettings, FitnessRule, Result
from robocompose.modular.params import ExperimentsConfig, ModularParams
from robocompose.modular.robot import PORT_XY
from robocompose.modular.truth import top_designs
from robocompose.params import build_config

MODULAR = ModularParams(EvalSettings(control_steps=10), FitnessRule(), ExperimentsConfig())
SECTION = {"fitness": {"source": "surrogate", "train_terrains": 6, "warmup": 20, "warmup_terrains": 4, "budget": 40,
                       "real_per_round": 4,
                       "surrogate": {"steps": 10, "hidden": 16}},
           "network": {"latent": 8, "hidden": 16, "filters": 4},
           "baselines": {"molgan": {"iterations": 6, "tasks": 2, "samples": 4, "n_critic": 2,
                                    "wgan_only_iterations": 2},
                         "dqn": {"iterations": 6, "tasks": 2, "episodes": 4, "updates": 2, "batch": 8, "start": 8,
                                 "replay": 32, "hidden": 16, "layers": 1}}}


@pytest.fixture
def fake_rollouts(monkeypatch):
    calls = []

    def fake(designs, terrain_seed, settings, rule, cache=None, executor=None, save_every=0):
        calls.append(list(designs))
        return [Result(None, "invalid", 0, 0.0) if rule.skips(d) else Result(float(d.count("w")) - terrain_seed % 3,
                                                                                "ok", 10, 0.01) for d in designs]

    monkeypatch.setattr(eggan_problem, "evaluate_designs", fake)
    return calls


def test_molgan_baseline_trains_on_the_shared_budget_and_answers_queries(tmp_path, fake_rollouts):
    params = build_config(EgganModularParams, SECTION, "test")
    metrics = train_baseline("molgan", MODULAR, params, None, None, tmp_path)
    # warm-up + real rounds spaced over the run's 6 x 2 evaluate calls, capped by the budget
    assert 20 < metrics["real_evaluations"] <= 40 and metrics["method"] == "MolGAN" and metrics["lam"] == 0.5
    saved = json.loads((tmp_path / "eggan_modular_molgan.json").read_text())
    assert saved["train"]["n_critic"] == 2 and "train_seconds" not in saved["metrics"]  # the file's bytes: params only
    assert REALTIME_METHODS == ("fit2form", "dqn", "molgan", "random", "portfolio", "ga", "crowding", "optimum")
    assert [method_title(m) for m in REALTIME_METHODS] == [
        "Fit2form", "DQN", "MolGAN", "Random sampling", "Portfolio (terrain-agnostic)", "EG-GAN", "EG-GAN-crowding",
        "Exhaustive optimum (oracle)"]  # Table 5.1's rows
    for method in ("fit2form", "ga", "crowding"):  # the other generators' files, stood in by MolGAN's
        (tmp_path / f"eggan_modular_{method}.pt").write_bytes((tmp_path / "eggan_modular_molgan.pt").read_bytes())
    train_baseline("dqn", MODULAR, params, None, None, tmp_path)  # the protocol wants every method's model
    problem = eggan_problem.ModularEgganProblem(MODULAR, params.fitness)
    proposers = realtime_proposers(problem, params, tmp_path, ["lwlwlw"] * 10, {1000: ["wwwwww"] * 10})
    assert list(proposers) == list(REALTIME_METHODS)
    for method in ("molgan", "dqn"):
        candidates = proposers[method](problem, 1000, 7, 10)
        assert len(set(candidates)) == 10 and all(len(d) == 6 for d in candidates)


def test_dqn_decision_groups_are_the_mirrored_port_pairs():
    for left, right in eggan_problem.ModularEgganProblem.decision_groups:
        assert PORT_XY[left][0] == PORT_XY[right][0] and PORT_XY[left][1] == -PORT_XY[right][1]


def test_dqn_baseline_spends_the_budget_and_proposes_ten_distinct_symmetric_designs(tmp_path, fake_rollouts):
    params = build_config(EgganModularParams, SECTION, "test")
    metrics = train_baseline("dqn", MODULAR, params, None, None, tmp_path)
    assert metrics["method"] == "DQN" and metrics["episodes"] == 6 * 2 * 4
    assert metrics["real_evaluations"] == sum(len(c) for c in fake_rollouts) > params.fitness.warmup  # real rounds ran
    saved = json.loads((tmp_path / "eggan_modular_dqn.json").read_text())
    assert saved["decision_groups"] == [[0, 5], [1, 4], [2, 3]] and "train_seconds" not in saved["metrics"]
    problem = make_problem(MODULAR, params, None, None)
    propose = dqn_answer(load_dqn(tmp_path / "eggan_modular_dqn.pt", problem)[0], 64)
    answer = propose(problem, 1000, 7, 10)
    assert len(answer) == len(set(answer)) == 10
    assert all(design == design[::-1] for design in answer)  # port order runs around the rim: mirrored = reversed
    assert propose(problem, 1000, 8, 10) == answer  # the greedy search has no randomness


def test_the_protocol_answers_from_the_tables_with_the_portfolio_and_the_oracle(fake_rollouts, synthetic_truth):
    # the best design depends on the terrain: wheels on 1007, legs on 1008 (fewer distances on 1008)
    truth = pd.concat([synthetic_truth(lambda d: float(d.count("w")), 1007),
                       synthetic_truth(lambda d: d.count("l") / 2, 1008)], ignore_index=True)
    params = build_config(EgganModularParams, {**SECTION, "protocol": {"test_terrains": [1007, 1008], "queries": 2,
                                                                       "candidates": 4, "ec_draws": 3}}, "test")
    chosen = ["lwlwlw", "bwbbwb", "wlwwlw", "lllwll"]  # a portfolio as the pool would pick it
    optima = {seed: top_designs(table, 4) for seed, table in truth.groupby("terrain_seed")}
    proposers = {"random": random_proposer, **table_proposers(chosen, optima)}
    problem = make_problem(MODULAR, params, None, None)
    table, query_ms = realtime_table(proposers, problem, MODULAR, params, truth)
    assert fake_rollouts == [] and set(query_ms) == {"random", "portfolio", "optimum"}  # no rollout: tables only
    assert len(table) == 3 * 2 * 2
    optimum = table[table.method == "optimum"].groupby("terrain_seed")
    assert optimum.max_distance.max().to_dict() == truth.groupby("terrain_seed").distance.max().to_dict() == \
        optimum.max_distance.min().to_dict() == {1007: 6.0, 1008: 3.0}
    assert (table[table.method == "optimum"].regret == 0).all()
    assert set(table[table.method == "optimum"].best_design) == {"wwwwww", "llllll"}  # the terrain's own optimum
    folio = table[table.method == "portfolio"]
    assert set(folio.best_design) == {"wlwwlw", "lllwll"}  # the same designs on both terrains, each best on one
    assert (folio.set_index(["terrain_seed", "query"]).regret > 0).all()
    with pytest.raises(InputError, match=r"protocol.test_terrains: .* missing \[1008\]"):
        realtime_table(proposers, problem, MODULAR, params, truth[truth.terrain_seed == 1007])
