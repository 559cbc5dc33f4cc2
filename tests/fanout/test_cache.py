import math

import pytest

from robocompose.fanout.cache import EvaluationCache

ROW = {"reward": 3.5, "status": "ok", "sim_steps": 100, "seconds": 1.5}


def test_cache_round_trips_and_saves_deterministic_bytes(tmp_path):
    path = tmp_path / "cache.parquet"
    cache = EvaluationCache(path)
    cache.put(("d2", "flat", "h", 0), **ROW)
    cache.put(("d1", "wall", "h", 1), **{**ROW, "reward": None, "status": "self_collision"})
    cache.save()
    again = EvaluationCache(path)
    assert len(again) == 2 and again.get(("d2", "flat", "h", 0)) == ROW
    assert again.get(("d1", "wall", "h", 1))["reward"] is None
    assert ("d2", "flat", "h", 1) not in again and again.get(("d2", "flat", "h", 1)) is None
    again.save()
    first = path.read_bytes()
    EvaluationCache(path).save()
    assert path.read_bytes() == first


def test_nan_reward_is_stored_as_null():
    cache = EvaluationCache()
    cache.put(("d", "flat", "h", 0), **{**ROW, "reward": math.nan, "status": "unstable"})
    assert cache.get(("d", "flat", "h", 0))["reward"] is None


def test_save_merges_entries_written_by_another_process(tmp_path):
    path = tmp_path / "cache.parquet"
    first, second = EvaluationCache(path), EvaluationCache(path)
    first.put(("a", "flat", "h", 0), **ROW)
    second.put(("b", "flat", "h", 0), **ROW)
    first.save()
    second.save()
    assert len(EvaluationCache(path)) == 2 and len(second) == 2


def test_bad_keys_and_values_are_refused():
    cache = EvaluationCache()
    with pytest.raises(ValueError, match="expected values"):
        cache.put(("d", "flat", "h", 0), reward=1.0)
    with pytest.raises(ValueError, match="expected values for"):
        cache.get(("d", "flat"))
    with pytest.raises(ValueError, match="not a column"):
        EvaluationCache(key_columns=("design_id", "terrain"))


def test_serves_another_table_such_as_the_team_costs(tmp_path):
    key = ("team", "chip_id", "settings_hash", "seed")
    cache = EvaluationCache(tmp_path / "teams.parquet", table="teams_team_costs", key_columns=key)
    cache.put(("3:1-0-2", "chip", "h", 0), team_cost=0.25)
    cache.save()
    again = EvaluationCache(tmp_path / "teams.parquet", table="teams_team_costs", key_columns=key)
    assert again.get(("3:1-0-2", "chip", "h", 0)) == {"team_cost": 0.25}
    with pytest.raises(ValueError, match="cannot merge"):
        again.merge(EvaluationCache())
