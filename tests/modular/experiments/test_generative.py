"""The learned baselines in the modular experiments: MolGAN and Whitman's DQN train on the shared problem and
budget, are saved with their metrics (no wall times), and answer the real-time protocol with the protocol's
number of distinct candidates; the DQN decides one module per mirrored port pair. The protocol answers every
candidate from the test terrains' exhaustive tables, with the portfolio and the exhaustive optimum as rows.

Rollouts are faked (distance = the number of wheels minus the terrain seed mod 3), as in test_eggan_problem.py;
the DQN's learning is tested on a toy problem in tests/eggan/test_dqn.py.
"""

from __future__ import annotations

import json

import pytest

from robocompose.eggan.dqn import load_dqn
from robocompose.eggan.learners import dqn_answer
from robocompose.fanout.executor import Executor
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.experiments.generative import (
    PREDICT,
    make_problem,
    method_info,
    method_title,
    realtime_methods,
    realtime_proposers,
    train_all,
    train_baseline,
    training_scores,
    validation_scores,
)
from robocompose.modular.experiments.table_designs import PREDICT_ROWS
from robocompose.modular.params import ExperimentsConfig, ModularParams
from robocompose.modular.plugins import eggan_problem
from robocompose.modular.plugins.eggan_problem import ModularEgganProblem
from robocompose.modular.robot import PORT_XY
from robocompose.params import build_config
from tests.modular.plugins.test_eggan_problem import fake_pool, table_fitness

MODULAR = ModularParams(EvalSettings(control_steps=10), FitnessRule(), ExperimentsConfig())
SECTION = {"fitness": {"source": "surrogate", "train_terrains": 6, "warmup": 20, "warmup_terrains": 4, "budget": 40,
                       "real_per_round": 4,
                       "surrogate": {"steps": 10, "hidden": 16}},
           "network": {"latent": 8, "hidden": 16, "filters": 4},
           "baselines": {"molgan": {"iterations": 6, "tasks": 2, "samples": 4, "n_critic": 2,
                                    "wgan_only_iterations": 2},
                         "dqn": {"iterations": 6, "tasks": 2, "episodes": 4, "updates": 2, "batch": 8, "start": 8,
                                 "replay": 32, "hidden": 16, "layers": 1},
                         "fit2form": {"iterations": 4, "tasks": 2, "samples": 4}}}


def test_molgan_baseline_trains_on_the_shared_budget_and_answers_queries(tmp_path, fake_rollouts):
    params = build_config(EgganModularParams, SECTION, "test")
    metrics = train_baseline("molgan", MODULAR, params, None, None, tmp_path)
    # warm-up + real rounds spaced over the run's 6 x 2 evaluate calls, capped by the budget
    assert 20 < metrics["real_evaluations"] <= 40 and metrics["method"] == "MolGAN" and metrics["lam"] == 0.5
    saved = json.loads((tmp_path / "eggan_modular_molgan.json").read_text())
    assert saved["train"]["n_critic"] == 2 and "train_seconds" not in saved["metrics"]  # the file's bytes: params only
    assert realtime_methods() == ("fit2form", "dqn", "molgan", "random", "portfolio", "portfolio_greedy",
                                  "predict_knn", "predict_ridge", "ga", "crowding", "crowding_diverse", "optimum")
    assert [method_title(m) for m in realtime_methods()] == [
        "Fit2form", "DQN", "MolGAN", "Random sampling", "Portfolio (terrain-agnostic baseline)",
        "Portfolio, greedy (terrain-agnostic)", "Predict the table, k-NN", "Predict the table, ridge", "EG-GAN",
        "EG-GAN-crowding", "EG-GAN-crowding, diverse query", "Exhaustive optimum (oracle)"]  # Table 5.1's rows
    assert method_info("crowding_diverse") == {"title": "EG-GAN-crowding, diverse query", "learned": False,
                                               "generator": "crowding"}  # the report prints its training spend
    assert method_info("predict_ridge") == {"title": "Predict the table, ridge", "learned": False}
    assert PREDICT == tuple(PREDICT_ROWS)  # the rows the stage's table_designs.predict_proposers answers
    for method in ("fit2form", "ga", "crowding"):  # the other generators' files, stood in by MolGAN's
        (tmp_path / f"eggan_modular_{method}.pt").write_bytes((tmp_path / "eggan_modular_molgan.pt").read_bytes())
    train_baseline("dqn", MODULAR, params, None, None, tmp_path)  # the protocol wants every method's model
    problem = eggan_problem.ModularEgganProblem(MODULAR, params.fitness)
    predict = {row: (lambda problem, terrain, query_seed, k: ["lwwwwl"]) for row in PREDICT}  # stand-ins
    with pytest.raises(ValueError, match=r"predict: expected the rows \['predict_knn', 'predict_ridge'\]"):
        realtime_proposers(problem, params, tmp_path, ["lwlwlw"] * 10, {1000: ["wwwwww"] * 10}, ["bbbwww"] * 10, {})
    proposers = realtime_proposers(problem, params, tmp_path, ["lwlwlw"] * 10, {1000: ["wwwwww"] * 10},
                                   ["bbbwww"] * 10, predict)
    assert list(proposers) == list(realtime_methods())
    assert proposers["portfolio_greedy"](problem, 1000, 7, 3) == ["bbbwww"] * 3
    assert proposers["predict_ridge"](problem, 1000, 7, 3) == ["lwwwwl"]
    diverse = proposers["crowding_diverse"](problem, 1000, 7, 10)  # the crowding file's generator (MolGAN's here)
    assert all(sum(x != y for x, y in zip(a, b, strict=True)) >= params.protocol.diverse_hamming == 2
               for i, a in enumerate(diverse) for b in diverse[:i])
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
    simulated = sum(len(d) for _, d in fake_rollouts)
    assert metrics["real_evaluations"] == simulated > params.fitness.warmup  # real rounds ran
    saved = json.loads((tmp_path / "eggan_modular_dqn.json").read_text())
    assert saved["decision_groups"] == [[0, 5], [1, 4], [2, 3]] and "train_seconds" not in saved["metrics"]
    problem = make_problem(MODULAR, params, None, None)
    propose = dqn_answer(load_dqn(tmp_path / "eggan_modular_dqn.pt", problem)[0], 64)
    answer = propose(problem, 1000, 7, 10)
    assert len(answer) == len(set(answer)) == 10
    assert all(design == design[::-1] for design in answer)  # port order runs around the rim: mirrored = reversed
    assert propose(problem, 1000, 8, 10) == answer  # the greedy search has no randomness


@pytest.mark.parametrize("name", ["fit2form", "dqn", "molgan"])
def test_every_baseline_trains_on_the_pool_tables_and_stops_at_the_shared_look_up_budget(tmp_path, name):
    pool = fake_pool(tmp_path, [20_000, 20_001, 20_002])
    section = {**SECTION, "fitness": {"source": "table", "train_terrains": 2, "validation_seed_base": 20_002,
                                      "validation_terrains": 1, "pool": str(pool), "lookups": 40},
               "baselines": {k: {**v, "iterations": 50} for k, v in SECTION["baselines"].items()}}
    metrics = train_baseline(name, MODULAR, build_config(EgganModularParams, section, "test"), None, None, tmp_path)
    assert metrics["fitness_source"] == "table" and metrics["evaluation_budget"] == 40
    assert metrics["real_evaluations"] <= 40 and metrics["surrogate_heldout"] is None
    if name != "dqn":  # DQN's symmetric space holds 2 x 36 valid designs: it may never reach 40 distinct ones
        assert metrics["iterations_done"] < 50  # the budget, not the iterations, ended training
    assert 0.0 <= metrics["final"]["val_regret"] and metrics["final"]["val_max_distance"] <= 6.0


def test_training_and_validation_scores_are_the_best_answered_table_entry_and_its_regret(tmp_path):
    """Odd pool seeds reward wheels, even ones legs (fake_pool): an answer of the most-wheeled designs is optimal
    on the odd terrains and short of the optimum on the even ones; scores are per-terrain bests, averaged."""
    problem = ModularEgganProblem(MODULAR, table_fitness(fake_pool(tmp_path, range(20_000, 20_004))))

    def wheels(problem, seed, query_seed, k):  # the k designs with the most wheels, whatever the terrain
        valid = [d for d in problem.table(seed) if not MODULAR.fitness.skips(d)]
        return sorted(valid, key=lambda d: (-d.count("w"), d))[:k]

    scores = {seed: max(problem.table(seed)[d] for d in wheels(problem, seed, 0, 3)) for seed in range(20_000, 20_004)}
    optima = {seed: max(problem.table(seed).values()) for seed in range(20_000, 20_004)}
    train = training_scores(problem, wheels, 3)
    assert train["train_max_distance"] == pytest.approx(sum(scores[s] for s in range(20_000, 20_003)) / 3)
    assert train["train_regret"] == pytest.approx(sum(optima[s] - scores[s] for s in range(20_000, 20_003)) / 3)
    assert validation_scores(problem, wheels, 3) == {"val_max_distance": scores[20_003],
                                                     "val_regret": optima[20_003] - scores[20_003]}
    assert optima[20_003] == scores[20_003] and optima[20_000] > scores[20_000]  # odd: wheels win; even: legs


def test_learners_trained_side_by_side_write_the_bytes_they_write_one_after_another(tmp_path, monkeypatch):
    """On the pool's tables every learner trains in its own worker process: the models, logs and metrics must
    not depend on it (each sets its own threads and seeds)."""
    pool = fake_pool(tmp_path, [20_000, 20_001, 20_002])
    section = {**SECTION, "fitness": {"source": "table", "train_terrains": 2, "validation_seed_base": 20_002,
                                      "validation_terrains": 1, "pool": str(pool), "lookups": 400},
               "train": {"iterations": 4, "batch": 8, "tasks": 2, "samples": 4, "log_every": 2,
                         "validate_every": 2, "checkpoint_every": 2},
               "protocol": {"candidates": 3, "samples": 8}}
    params = build_config(EgganModularParams, section, "test")
    monkeypatch.chdir(tmp_path)  # the EG-GAN curves go to reports/plots/
    runs = {}
    for workers in (1, 2):
        out = tmp_path / f"workers{workers}"
        with Executor(workers=workers) as executor:
            metrics, seconds = train_all(MODULAR, params, None, executor, out)
        assert list(metrics) == list(seconds) == ["ga", "crowding", "fit2form", "dqn", "molgan"]
        assert all("seconds" not in m for m in metrics.values())  # wall times go to timings, not to outputs
        runs[workers] = (metrics, {p.relative_to(out): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()})
    assert runs[1][0] == runs[2][0]
    assert runs[1][1].keys() == runs[2][1].keys() and len(runs[1][1]) >= 10
    assert all(runs[1][1][name] == runs[2][1][name] for name in runs[1][1])


def test_this_module_imports_every_learner_it_runs_through_the_registry():
    """The registry names its learners' modules without importing them: this module, which trains and loads every
    modular learner, imports them itself, so its import closure (its stages' code deps) holds their code."""
    from robocompose.eggan.learners import ref_modules
    from robocompose.io.provenance import import_closure, module_path

    closure = import_closure("robocompose.modular.experiments.generative")
    assert ref_modules("modular") and all(module_path(m) in closure for m in ref_modules("modular"))
