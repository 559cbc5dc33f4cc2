"""The MolGAN baseline in the modular experiments: trained on the shared problem and budget, saved with its
metrics, and answering the real-time protocol with the protocol's number of distinct candidates.

Rollouts are faked (distance = the number of wheels minus the terrain seed mod 3), as in test_eggan_problem.py.
"""

from __future__ import annotations

import json

from robocompose.modular import eggan_problem
from robocompose.modular.eggan_experiments import REALTIME_METHODS, realtime_proposers, train_molgan_baseline
from robocompose.modular.eggan_params import build_eggan_modular_params
from robocompose.modular.evaluate import EvalSettings, FitnessRule, Result
from robocompose.modular.params import ExperimentsConfig, ModularParams

MODULAR = ModularParams(EvalSettings(control_steps=10), FitnessRule(), ExperimentsConfig())
SECTION = {"fitness": {"train_terrains": 6, "warmup": 20, "warmup_terrains": 4, "budget": 40, "real_per_round": 4,
                       "surrogate": {"steps": 10, "hidden": 16}},
           "network": {"latent": 8, "hidden": 16, "filters": 4},
           "baselines": {"molgan": {"iterations": 6, "tasks": 2, "samples": 4, "n_critic": 2,
                                    "wgan_only_iterations": 2}}}


def fake_rollouts(designs, terrain_seed, settings, rule, cache=None, executor=None, save_every=0):
    return [Result(None, "invalid", 0, 0.0) if rule.skips(d) else Result(float(d.count("w")) - terrain_seed % 3,
                                                                            "ok", 10, 0.01) for d in designs]


def test_molgan_baseline_trains_on_the_shared_budget_and_answers_queries(tmp_path, monkeypatch):
    monkeypatch.setattr(eggan_problem, "evaluate_designs", fake_rollouts)
    params = build_eggan_modular_params(SECTION, "test")
    metrics = train_molgan_baseline(MODULAR, params, None, None, tmp_path)
    # warm-up + real rounds spaced over the run's 6 x 2 evaluate calls, capped by the budget
    assert 20 < metrics["real_evaluations"] <= 40 and metrics["method"] == "MolGAN" and metrics["lam"] == 0.5
    saved = json.loads((tmp_path / "eggan_modular_molgan.json").read_text())
    assert saved["train"]["n_critic"] == 2 and "train_seconds" not in saved["metrics"]  # the file's bytes: params only
    assert REALTIME_METHODS["molgan"] == "MolGAN"
    for method in ("fit2form", "ga", "crowding"):  # the other generators' files, stood in by MolGAN's
        (tmp_path / f"eggan_modular_{method}.pt").write_bytes((tmp_path / "eggan_modular_molgan.pt").read_bytes())
    problem = eggan_problem.ModularEgganProblem(MODULAR, params.fitness)
    candidates = realtime_proposers(problem, params, tmp_path)["molgan"](problem, 1000, 7, 10)
    assert len(set(candidates)) == 10 and all(len(d) == 6 for d in candidates)

