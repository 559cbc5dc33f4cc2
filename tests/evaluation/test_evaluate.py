import math

import numpy as np
import pytest

import robocompose.evaluation.evaluate as ev
from robocompose.control.mppi import Episode, MPPIConfig
from robocompose.evaluation.evaluate import EvaluationConfig, evaluate, evaluate_designs, objective
from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.grammar.derivation import derive, parse_rules
from robocompose.io.errors import InputError
from robocompose.params import build_config

RIDGED_BEST = "0,7,1,13,1,2,16,12,13,6,4,19,4,17,5,3,2,16,4,5,18,9,8,9,9,8"
SELF_PENETRATING = "0,2,17,10,6,4,16,5,9,8,7"  # its two limbs overlap when placed
TINY = EvaluationConfig(mppi=MPPIConfig(samples=4, first_samples=4, horizon=4, episode=6))


@pytest.fixture(scope="module")
def tree():
    return derive(parse_rules(RIDGED_BEST)).tree


def test_evaluation_runs_the_mppi_episode_and_counts_its_steps(tree):
    row = evaluate(tree, "flat", TINY, seed=0)
    assert row["status"] == "ok" and 3.0 < row["reward"] < 6.0
    assert row["sim_steps"] == TINY.mppi.sim_steps()
    wall = evaluate(tree, "wall", TINY, seed=0)  # twice the horizon on the wall task
    assert wall["sim_steps"] == TINY.mppi.sim_steps(2 * TINY.mppi.horizon)


def test_evaluation_is_reproducible_given_the_seed(tree):
    a, b, c = (evaluate(tree, "ridged", TINY, seed=s)["reward"] for s in (1, 1, 2))
    assert a == b and a != c


def test_self_penetrating_design_is_not_simulated():
    row = evaluate(derive(parse_rules(SELF_PENETRATING)).tree, "flat", TINY, seed=0)
    assert row["status"] == "self_collision" and row["reward"] is None and row["sim_steps"] == 0
    assert objective(row) == 3.8


@pytest.mark.parametrize(("reward", "status", "stored"), [(12.0, "unstable", 12.0), (math.nan, "unstable", None),
                                                         (9.9, "ok", 9.9)])
def test_blow_ups_are_unstable_not_scores(monkeypatch, tree, reward, status, stored):
    monkeypatch.setattr(ev, "run_episode", lambda *a, **k: Episode(reward, 1, np.zeros((1, 1)), np.zeros(1)))
    row = evaluate(tree, "flat", TINY, seed=0)
    assert row["status"] == status and row["reward"] == stored
    assert objective(row) == (4.0 if status == "unstable" else 9.9)


def test_settings_hash_separates_settings_and_params_build_nested_config():
    config = build_config(EvaluationConfig, {"mppi": {"samples": 4, "first_samples": 4, "horizon": 4, "episode": 6}},
                          "evaluation")
    assert config.mppi == TINY.mppi and config.settings_hash("flat") == TINY.settings_hash("flat")
    assert EvaluationConfig().settings_hash("flat") != TINY.settings_hash("flat")
    with pytest.raises(InputError, match="evaluation.mppi.samples: expected int"):
        build_config(EvaluationConfig, {"mppi": {"samples": "many"}}, "evaluation")


def test_evaluate_designs_on_processes_fills_the_cache(tmp_path, tree):
    cache = EvaluationCache(tmp_path / "cache.parquet")
    config = EvaluationConfig(mppi=MPPIConfig(samples=2, first_samples=2, horizon=2, episode=2))
    with Executor(workers=2) as executor:
        table = evaluate_designs([tree], ["flat", "frozen_lake"], config, seeds=[0], cache=cache, executor=executor)
    assert table["task"].tolist() == ["flat", "frozen_lake"] and (table["status"] == "ok").all()
    assert table["design_id"].tolist() == [tree.design_id] * 2 and len(EvaluationCache(cache.path)) == 2
    inline = evaluate(tree, "frozen_lake", config, seed=0)
    assert table["reward"].iloc[1] == inline["reward"]  # same result in a worker process


def test_design_without_hinges_is_scored_and_makes_no_progress():
    from robocompose.control.mppi import MPPIConfig
    from robocompose.evaluation.evaluate import EvaluationConfig, evaluate
    from robocompose.grammar.derivation import derive, parse_rules

    tree = derive(parse_rules("0,7,1,10,3,3,6")).tree  # two bodies joined by a fixed joint
    assert tree.n_joints == 0
    config = EvaluationConfig(mppi=MPPIConfig(samples=2, first_samples=2, horizon=2, episode=4))
    row = evaluate(tree, "flat", config, seed=0)
    assert row["status"] == "ok"
    assert abs(row["reward"] - 4.0) < 0.05  # upright and facing forward, but no velocity term


def test_every_sibling_order_of_a_design_builds_one_robot_and_scores_the_same(tree, reorder):
    other = reorder(tree)  # the ridged reference with every node's children reversed
    assert other.tokens != tree.tokens and other.design_id == tree.design_id
    a, b = evaluate(tree, "ridged", TINY, seed=3), evaluate(other, "ridged", TINY, seed=3)
    assert a["reward"] == b["reward"] and a["sim_steps"] == b["sim_steps"]


@pytest.mark.parametrize("module, name, value", [
    ("robocompose.tasks.terrains", "TERRAIN_SEED", 1),  # the obstacles' positions
    ("robocompose.tasks.terrains", "START_X", 0.5),
    ("robocompose.sim.builder", "LINK_FRICTION", 0.8),  # robot and motor constants
    ("robocompose.sim.builder", "KP", 0.02),
    ("robocompose.grammar.tree", "BODY_TOTAL_MASS", 0.5),
    ("robocompose.evaluation.evaluate", "BLOWUP_REWARD", 11.0),
])
def test_settings_hash_changes_with_every_constant_that_shapes_a_result(monkeypatch, module, name, value):
    import importlib

    before = TINY.settings_hash("ridged")
    monkeypatch.setattr(importlib.import_module(module), name, value)
    assert TINY.settings_hash("ridged") != before


def test_settings_hash_covers_the_task_physics_and_code(monkeypatch):
    from dataclasses import replace

    import robocompose.sim.physics as physics
    import robocompose.tasks.terrains as terrains

    base = {t: TINY.settings_hash(t) for t in ("flat", "wall")}
    assert base["flat"] != base["wall"] and TINY.settings_hash("flat") == base["flat"]  # unchanged: same key
    monkeypatch.setitem(terrains.TASKS, "flat", replace(terrains.TASKS["flat"], friction=0.4))
    assert TINY.settings_hash("flat") != base["flat"]
    monkeypatch.undo()
    monkeypatch.setattr(physics.PhysicsSettings, "__init__", _with_default(physics.PhysicsSettings, gravity=-9.0))
    assert TINY.settings_hash("flat") != base["flat"]
    monkeypatch.undo()
    # any edit of the evaluator's code
    monkeypatch.setattr(ev, "result_digest", lambda *entries: "changed-source")
    assert TINY.settings_hash("flat") != base["flat"]


def _with_default(cls, **defaults):
    init = cls.__init__

    def patched(self, **kwargs):
        init(self, **{**defaults, **kwargs})
    return patched


def test_cached_evaluations_read_entries_under_the_old_key_formula(tree, monkeypatch):
    """The key (design id, task, settings hash, seed) is what the cache files already hold: no re-keying."""
    from robocompose.evaluation.evaluate import EvalJob, cached_evaluations

    cache = EvaluationCache()
    old_key = (tree.design_id, "flat", TINY.settings_hash("flat"), 3)
    cache.put(old_key, reward=4.25, status="ok", sim_steps=7, seconds=1.0)
    monkeypatch.setattr(ev, "evaluate", lambda *a, **k: pytest.fail("a cached entry was evaluated again"))
    [row] = cached_evaluations([EvalJob(tree, "flat", TINY, 3)], cache)
    assert row == {"design_id": tree.design_id, "task": "flat", "settings_hash": old_key[2], "seed": 3,
                   "reward": 4.25, "status": "ok", "sim_steps": 7, "seconds": 1.0}
