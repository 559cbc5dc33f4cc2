import numpy as np
import pandas as pd
import pytest

from robocompose.evaluation.cache import EvaluationCache
from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.experiments import (
    METHODS,
    baseline_runs,
    ec_answers,
    emergency_constraints,
    exhaustive_table,
    run_method,
    satisfies,
    truth_summary,
)
from robocompose.modular.params import ExperimentsConfig, ModularParams
from robocompose.modular.robot import valid_in_original

TINY = ModularParams(EvalSettings(control_steps=3, settle_steps=10), FitnessRule(),
                     ExperimentsConfig(test_terrains=[7], ga_seeds=[0], generations=2, random_designs=4, ec_draws=3))
SUBSET = ["llllll", "wwwwww", "bbbbbb", "lwlwlw", "nnnnnn", "lnllnl", "wlwwlw", "bwbbwb"]


def test_exhaustive_table_scores_every_design_and_summarises_the_optimum():
    cache = EvaluationCache()
    table = exhaustive_table(TINY, cache, None, designs=SUBSET)
    assert list(table.design) == sorted(SUBSET) and (table.terrain_seed == 7).all()
    assert table.set_index("design").loc["nnnnnn", "status"] == "invalid"
    assert len(cache) == len(SUBSET) - 1
    summary = truth_summary(table, epsilon=0.5).iloc[0]
    assert summary.optimum == table.fitness.max()
    assert summary.near_optimal == int((table.fitness >= table.fitness.max() - 0.5).sum())
    assert summary.best_design == table.sort_values("fitness").design.iloc[-1]


def test_runs_are_seeded_and_the_cache_makes_reruns_free(tmp_path):
    cache = EvaluationCache(tmp_path / "c.parquet")
    first = run_method("ga20", 7, 0, TINY, cache)
    assert first.evaluations == 40 and first.best_distance >= first.result.fitness.max()
    again = run_method("ga20", 7, 0, TINY, cache)
    assert again.best_design == first.best_design and again.sim_steps == first.sim_steps
    assert again.sim_seconds == pytest.approx(first.sim_seconds)
    with pytest.raises(ValueError, match="method"):
        run_method("ga100", 7, 0, TINY, cache)


def test_emergency_answers_respect_the_cap():
    rng = np.random.default_rng(0)
    constraints = emergency_constraints(rng, 50)
    assert {m for m, _ in constraints} == set("lwb") and {c for _, c in constraints} == {0, 1, 2}
    answers = ec_answers(["llllll", "wwwwww"], np.array([5.0, 1.0]), [("w", 0), ("l", 0), ("l", 1)], rng)
    assert answers[0] == "llllll" and answers[1] == "wwwwww"
    assert satisfies(answers[2], ("l", 1)) and answers[2] not in ("llllll",)  # no output qualifies: random
    feasible = ec_answers(["llllll"], np.array([5.0]), [("l", 0)] * 30, rng, feasible=valid_in_original)
    assert all(valid_in_original(d) and "l" not in d for d in feasible) and len(set(feasible)) > 10


def test_baseline_runs_table_has_every_method_and_regret_inputs():
    cache = EvaluationCache()
    truth = exhaustive_table(TINY, cache, None, designs=SUBSET)
    one_generation = ModularParams(TINY.eval, TINY.fitness, ExperimentsConfig(
        test_terrains=[7], ga_seeds=[0], generations=1, random_designs=4, ec_draws=3))
    runs = baseline_runs(one_generation, truth, cache, None)
    assert sorted(runs.method) == sorted(METHODS)
    assert (runs.optimum == truth.fitness.max()).all()
    assert runs.set_index("method").loc["random", "evaluations"] == 4
    assert runs.set_index("method").loc["ga50", "evaluations"] == 50
    assert (runs.sim_steps > 0).all() and (runs.distinct >= 1).all()
    with pytest.raises(ValueError, match="exhaustive"):
        baseline_runs(TINY, pd.DataFrame(columns=truth.columns), cache, None)
