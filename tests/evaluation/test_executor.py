import math
import os

import pytest

from robocompose.evaluation.cache import EvaluationCache
from robocompose.evaluation.executor import Executor, evaluate_many


def _row(item):
    design, value = item
    if value < 0:
        raise RuntimeError(f"evaluation of {design} failed")
    return {"reward": float(value), "status": "ok", "sim_steps": 1, "seconds": 0.0}


def _key(item):
    return (item[0], "flat", "h", 0)


def test_local_processes_return_results_in_order():
    with Executor(workers=2) as ex:
        assert ex.backend == "processes"
        assert ex.map(math.factorial, range(8)) == [math.factorial(i) for i in range(8)]
        assert ex.map(abs, [-3, 2]) == [3, 2]  # the pool is reused
        assert ex.map(abs, []) == []
    assert Executor(workers=1).backend == "inline"
    with pytest.raises(ValueError, match="workers"):
        Executor(workers=-1)


def test_evaluate_many_evaluates_each_missing_key_once(tmp_path):
    calls = []

    def counted(item):
        calls.append(item)
        return _row(item)

    cache = EvaluationCache(tmp_path / "cache.parquet")
    cache.put(_key(("cached", 0)), **_row(("cached", 9)))
    items = [("a", 1), ("b", 2), ("a", 1), ("cached", 0)]
    rows = evaluate_many(counted, items, _key, cache=cache)
    assert [r["reward"] for r in rows] == [1.0, 2.0, 1.0, 9.0]
    assert calls == [("a", 1), ("b", 2)]
    assert len(EvaluationCache(tmp_path / "cache.parquet")) == 3  # saved


def test_a_failing_evaluation_propagates_and_earlier_results_are_kept(tmp_path):
    cache = EvaluationCache(tmp_path / "cache.parquet")
    with pytest.raises(RuntimeError, match="evaluation of bad failed"):
        evaluate_many(_row, [("good", 1), ("bad", -1)], _key, cache=cache)
    assert _key(("good", 1)) in EvaluationCache(tmp_path / "cache.parquet")


def test_dask_cluster_backend():
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        with Executor(address=cluster.scheduler_address) as ex:
            assert ex.backend == "dask"
            pids = ex.map(lambda _: os.getpid(), range(6))
            assert os.getpid() not in pids
            rows = evaluate_many(lambda item: {"reward": float(item[1]), "status": "ok", "sim_steps": 2,
                                               "seconds": 0.0},
                                 [("a", 1), ("b", 2)], _key, executor=ex)
            assert [r["reward"] for r in rows] == [1.0, 2.0]
