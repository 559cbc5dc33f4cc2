import numpy as np
import pandas as pd
import pytest

from robocompose.control.mppi import MPPIConfig
from robocompose.dataset.enumerate import design_row
from robocompose.evaluation import evaluate
from robocompose.evaluation.evaluate import EvaluationConfig
from robocompose.evaluation.references import (
    ReferencesConfig,
    best_per_task,
    candidate_designs,
    commit_evaluations,
    committed_evaluations,
    evaluate_references,
    record_best,
)
from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.grammar.derivation import random_derivation
from robocompose.grammar.references import REFERENCE_DESIGNS
from robocompose.io import read_mcap, read_table, write_table

TINY = EvaluationConfig(mppi=MPPIConfig(samples=2, first_samples=2, horizon=2, episode=4))


@pytest.fixture(scope="module")
def designs():
    rows = []
    for seed in range(40):
        derivation = random_derivation(np.random.default_rng(seed))
        if derivation is not None and derivation.tree.n_links >= 5:
            rows.append(design_row(derivation.tree, derivation.rules, np.zeros(16)))
    return pd.DataFrame(rows[:5])


def test_candidates_are_the_references_then_seeded_random_designs(designs):
    config = ReferencesConfig(n_random=3, seed=1)
    candidates = candidate_designs(designs, config)
    assert list(candidates["name"]) == [*REFERENCE_DESIGNS, "random_0", "random_1", "random_2"]
    assert set(candidates["design_id"][2:]) <= set(designs["design_id"])
    assert candidates["design_id"].tolist() == candidate_designs(designs, config)["design_id"].tolist()
    with pytest.raises(ValueError, match="dataset holds 5"):
        candidate_designs(designs, ReferencesConfig(n_random=6))
    with pytest.raises(ValueError, match="known tasks"):
        ReferencesConfig(tasks=["moon"])


def test_table_best_designs_and_their_logs(tmp_path, designs):
    config = ReferencesConfig(n_random=1, tasks=["flat", "ridged"])
    table = evaluate_references(designs, config, TINY)
    assert len(table) == 6 and table["task"].tolist()[:2] == ["flat", "ridged"]
    ok = table["status"] == "ok"
    assert (table.loc[ok, "objective"] == table.loc[ok, "reward"]).all()
    write_table(table, tmp_path / "t.parquet", "reference_evals")
    pd.testing.assert_frame_equal(read_table(tmp_path / "t.parquet", "reference_evals"), table, check_dtype=False)
    best = best_per_task(table)
    assert list(best["task"]) == ["flat", "ridged"]
    assert best["reward"].iloc[0] == table.loc[ok & (table["task"] == "flat"), "reward"].max()
    with Executor(workers=2) as executor:  # replays run in workers and come back with their recorders
        written = record_best(table, designs, config, TINY, tmp_path / "rollouts", (32, 24), executor)
    assert sorted(p.name for p in written) == ["flat.gif", "flat.mcap", "ridged.gif", "ridged.mcap"]
    assert any(m.topic == "/tf" for m in read_mcap(tmp_path / "rollouts" / "flat.mcap"))


def test_committed_evaluations_are_served_while_their_settings_match(tmp_path, designs, monkeypatch):
    config = ReferencesConfig(n_random=1, tasks=["flat"])
    cache = EvaluationCache()
    table = evaluate_references(designs, config, TINY, cache)
    path = commit_evaluations(table, cache, tmp_path / "measured" / "eval_cache.parquet")
    assert committed_evaluations(tmp_path / "absent.parquet").frame().empty  # no file: nothing served
    committed = committed_evaluations(path)
    assert len(committed) == len(table) == 3

    def no_simulation(*args, **kwargs):
        raise AssertionError("a committed evaluation was simulated again")

    monkeypatch.setattr(evaluate, "evaluate", no_simulation)
    pd.testing.assert_frame_equal(evaluate_references(designs, config, TINY, committed), table)
    # another controller setting: its settings hash keys other entries, so nothing committed is served
    other = EvaluationConfig(mppi=MPPIConfig(samples=2, first_samples=2, horizon=2, episode=6))
    with pytest.raises(AssertionError, match="simulated again"):
        evaluate_references(designs, config, other, committed)
