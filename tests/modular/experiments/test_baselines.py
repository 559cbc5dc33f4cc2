import numpy as np
import pandas as pd
import pytest

from robocompose.fanout.cache import EvaluationCache
from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.experiments.baselines import (
    METHODS,
    baseline_runs,
    ec_answers,
    emergency_constraints,
    run_method,
    satisfies,
    table_results,
)
from robocompose.modular.params import ExperimentsConfig, ModularParams
from robocompose.modular.robot import valid_in_original

TINY = ModularParams(EvalSettings(control_steps=3, settle_steps=10), FitnessRule(),
                     ExperimentsConfig(test_terrains=[1007], truth_terrains=[1007], ga_seeds=[0], generations=2,
                                       random_designs=4, ec_draws=3))


def test_runs_are_seeded_and_the_cache_makes_reruns_free(tmp_path):
    cache = EvaluationCache(tmp_path / "c.parquet")
    first = run_method("ga20", 1007, 0, TINY, cache)
    assert first.evaluations == 40 and first.best_fitness >= first.result.fitness.max()
    again = run_method("ga20", 1007, 0, TINY, cache)
    assert again.best_design == first.best_design and again.sim_steps == first.sim_steps
    assert again.sim_seconds == pytest.approx(first.sim_seconds)
    with pytest.raises(ValueError, match="method"):
        run_method("ga100", 1007, 0, TINY, cache)


def test_a_run_on_a_known_table_reads_every_fitness_from_it(synthetic_truth):
    known = table_results(synthetic_truth(lambda d: float(d.count("w"))))
    run = run_method("ga50", 1007, 0, TINY, known=known)
    assert run.best_fitness == known[run.best_design].distance >= max(
        known[d].distance or -10 for d in run.result.population)
    # Each evaluation costs the steps and seconds its table row records (0.5 s per 100 steps here).
    assert run.sim_steps > 0 and run.sim_seconds == pytest.approx(0.5 * run.sim_steps / 100)


def test_emergency_answers_are_valid_designs_within_the_cap():
    rng = np.random.default_rng(0)
    constraints = emergency_constraints(rng, 50)
    assert {m for m, _ in constraints} == set("lwb") and {c for _, c in constraints} == {0, 1, 2}
    # The fittest output design is invalid (an empty corner port): the answer is the best valid one.
    answers = ec_answers(["nlllll", "llllll", "wwwwww"], np.array([9.0, 5.0, 1.0]),
                         [("w", 0), ("l", 0), ("l", 1)], rng, valid=valid_in_original)
    assert answers[:2] == ["llllll", "wwwwww"]
    assert satisfies(answers[2], ("l", 1)) and valid_in_original(answers[2])  # no output qualifies: random
    drawn = ec_answers(["nlllll"], np.array([5.0]), [("l", 0)] * 30, rng, valid=valid_in_original)
    assert all(valid_in_original(d) and "l" not in d for d in drawn) and len(set(drawn)) > 10


def test_baseline_runs_report_distances_and_count_failures_never_averaging_penalties(synthetic_truth):
    e = ExperimentsConfig(test_terrains=[1007], truth_terrains=[1007], ga_seeds=[0], generations=1,
                          random_designs=4, ec_draws=3)
    params = ModularParams(TINY.eval, TINY.fitness, e)
    truth = synthetic_truth(lambda d: float(d.count("w")))
    runs = baseline_runs(params, truth).set_index("method")
    assert sorted(runs.index) == sorted(METHODS)
    assert (runs.optimum == 6.0).all() and runs.loc["random", "evaluations"] == 4
    assert runs.loc["ga50", "evaluations"] == 50 and (runs.sim_seconds > 0).sum() >= 3
    ga = runs.loc[["ga20", "ga50", "crowding"]]
    assert ga.best_distance.between(0.0, 6.0).all() and (runs.ec_failures == 0).all()
    # Every valid design unstable but six wheels: distances only where measured, failures as counts.
    only_wheels = baseline_runs(params, synthetic_truth(lambda d: 6.0 if d == "wwwwww" else None)).set_index("method")
    random = only_wheels.loc["random"]
    assert pd.isna(random.best_distance) and random.ec_failures + (0 if pd.isna(random.ec_distance) else 1) >= 2
    assert (only_wheels.ec_distance.dropna() == 6.0).all()
    with pytest.raises(ValueError, match="exhaustive"):
        baseline_runs(params, truth.iloc[:0])
