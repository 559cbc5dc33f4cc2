import math
import os
import socket
import time
from pathlib import Path

import pandas as pd
import pytest

from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor, evaluate_many
from robocompose.io.errors import InputError


def _row(item):
    design, value = item
    if value < 0:
        raise RuntimeError(f"evaluation of {design} failed")
    return {"reward": float(value), "status": "ok", "sim_steps": 1, "seconds": 0.0}


def _key(item):
    return (item[0], "flat", "h", 0)


def _slow_row(item):
    """_row after sleeping the item's value in seconds."""
    time.sleep(item[1])
    return _row(item)


SLOW_FIRST = [("slow", 0.5), ("a", 0), ("b", 0), ("c", 0)]  # the first item takes longest


class _PutOrder(EvaluationCache):
    """A cache that records the order its rows arrive in."""

    def __init__(self):
        super().__init__()
        self.arrivals = []

    def put(self, key, **values):
        self.arrivals.append(key[0])
        super().put(key, **values)


def test_local_processes_return_results_in_order():
    with Executor(workers=2) as ex:
        assert ex.backend == "processes"
        assert ex.map(math.factorial, range(8)) == [math.factorial(i) for i in range(8)]
        assert ex.map(abs, [-3, 2]) == [3, 2]  # the pool is reused
        assert ex.map(abs, []) == []
    assert Executor(workers=1).backend == "inline"
    with pytest.raises(ValueError, match="workers"):
        Executor(workers=-1)


@pytest.mark.parametrize("backend", ["processes", "dask"])
def test_a_slow_first_item_holds_up_neither_later_results_nor_their_order(backend, request):
    address = request.getfixturevalue("dask_address") if backend == "dask" else None
    with Executor(workers=2, address=address) as ex:
        assert ex.backend == backend
        finished = [index for index, _ in ex.as_completed(_slow_row, SLOW_FIRST)]
        assert sorted(finished) == [0, 1, 2, 3] and finished[0] != 0  # a later item was handled first
        assert [r["reward"] for r in ex.map(_slow_row, SLOW_FIRST)] == [0.5, 0.0, 0.0, 0.0]  # item order
        cache = _PutOrder()
        rows = evaluate_many(_slow_row, SLOW_FIRST, _key, cache=cache, executor=ex)
    assert cache.arrivals[0] != "slow" and sorted(cache.arrivals) == ["a", "b", "c", "slow"]  # cached as they came
    assert [r["reward"] for r in rows] == [0.5, 0.0, 0.0, 0.0]


def test_in_this_process_items_complete_in_order():
    with Executor(workers=1) as ex:
        assert list(ex.as_completed(abs, [-3, 2, -1])) == [(0, 3), (1, 2), (2, 1)]


def test_a_progress_label_shows_a_bar_without_changing_results(capsys):
    with Executor(workers=2, progress="scoring") as ex:
        assert ex.map(abs, [-3, 2, -1]) == [3, 2, 1]
    bar = capsys.readouterr().err
    assert "scoring" in bar and "3/3" in bar
    with Executor(workers=1) as ex:
        ex.map(abs, [-1])
    assert capsys.readouterr().err == ""  # no label, no bar


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


def test_dask_cluster_backend(dask_address):
    with Executor(address=dask_address) as ex:
        assert ex.backend == "dask"
        pids = ex.map(lambda _: os.getpid(), range(6))
        assert os.getpid() not in pids
        rows = evaluate_many(lambda item: {"reward": float(item[1]), "status": "ok", "sim_steps": 2, "seconds": 0.0},
                             [("a", 1), ("b", 2)], _key, executor=ex)
        assert [r["reward"] for r in rows] == [1.0, 2.0]


# --- a real Dask cluster (`dask_address`, tests/conftest.py): every kind of fan-out gives what local processes give ---

def test_enumeration_on_a_dask_cluster_is_byte_identical_to_local_processes(dask_address, tmp_path):
    from robocompose.dataset.enumerate import EnumerateConfig, enumerate_designs
    from robocompose.io import write_table

    with Executor(workers=2) as local_executor, Executor(address=dask_address) as remote_executor:
        local, _ = enumerate_designs(EnumerateConfig(n=6, seed=3, chunk=8), local_executor, progress=None)
        remote, _ = enumerate_designs(EnumerateConfig(n=6, seed=3, chunk=8), remote_executor, progress=None)
    paths = [write_table(t, tmp_path / f"{name}.parquet", "designs") for name, t in (("l", local), ("d", remote))]
    assert paths[0].read_bytes() == paths[1].read_bytes()


def test_grammar_and_modular_evaluations_on_a_dask_cluster_match_local_processes(dask_address):
    from robocompose.control.mppi import MPPIConfig
    from robocompose.evaluation.evaluate import EvaluationConfig, evaluate_designs
    from robocompose.grammar.derivation import derive, parse_rules
    from robocompose.grammar.references import REFERENCE_DESIGNS
    from robocompose.modular import evaluate as modular

    trees = [derive(parse_rules(rules)).tree for rules in REFERENCE_DESIGNS.values()]
    config = EvaluationConfig(mppi=MPPIConfig(samples=4, first_samples=4, horizon=4, episode=4))
    settings, rule = modular.EvalSettings(control_steps=8), modular.FitnessRule()
    designs = ["wwwwww", "llllll", "lwblwb"]
    with Executor(workers=2) as local, Executor(address=dask_address) as remote:
        assert remote.backend == "dask"
        grammar = [evaluate_designs(trees, ["flat"], config, executor=ex).drop(columns="seconds") for ex in
                   (local, remote)]
        robots = [modular.evaluate_designs(designs, 4, settings, rule, executor=ex) for ex in (local, remote)]
    assert grammar[0].equals(grammar[1])
    assert [(r.distance, r.status, r.sim_steps) for r in robots[0]] == \
           [(r.distance, r.status, r.sim_steps) for r in robots[1]]


def test_teams_experiments_on_a_dask_cluster_match_local_processes(dask_address, tmp_path):
    from robocompose.teams.chips import ChipsConfig, prepare_chips
    from robocompose.teams.decompose import DecomposeConfig, regions_table
    from robocompose.teams.ergodic import CoverageConfig
    from robocompose.teams.evaluator import teams_cache
    from robocompose.teams.experiments import decomposed_chips, nsga2_runs
    from robocompose.teams.params import ExperimentsConfig

    chips = prepare_chips(ChipsConfig(n_synthetic=2, seed=2), tmp_path / "chips")
    test_chips = decomposed_chips(regions_table(chips, DecomposeConfig(n_regions=3, test_fraction=0.5)), "test")
    coverage = CoverageConfig(iterations=3, n_observations=5)
    experiments = ExperimentsConfig(populations=[4], generations=2, table_5_4_chips=1, seeds=[0, 1], budgets=[3])
    with Executor(workers=2) as local, Executor(address=dask_address) as remote:
        out = [nsga2_runs(test_chips, coverage, experiments, teams_cache(), ex)[:2] for ex in (local, remote)]
    for a, b in zip(out[0], out[1], strict=True):
        pd.testing.assert_frame_equal(a, b)


def test_a_batched_evaluator_gets_the_missing_items_in_chunks():
    chunks = []

    def batched(items):
        chunks.append([design for design, _ in items])
        return [_row(item) for item in items]

    cache = EvaluationCache()
    cache.put(_key(("b", 0)), **_row(("b", 7)))
    items = [("a", 1), ("b", 2), ("c", 3), ("a", 1), ("d", 4), ("e", 5)]
    rows = evaluate_many(batched, items, _key, cache=cache, batch=2)
    assert [r["reward"] for r in rows] == [1.0, 7.0, 3.0, 1.0, 4.0, 5.0]
    assert chunks == [["a", "c"], ["d", "e"]]  # the cached "b" and the repeated "a" are not evaluated


@pytest.mark.parametrize("address", ["localhost:8786", "tcp://host", "tcp://host:99999", "http://host:8786",
                                     "tcp://ho st:8786", "tcp://host:8786/x"])
def test_a_malformed_address_is_refused_at_once_with_one_line(address):
    started = time.perf_counter()
    with pytest.raises(InputError, match="expected a Dask scheduler address like tcp://host:8786") as error:
        Executor(address=address)
    assert time.perf_counter() - started < 1 and repr(address) in str(error.value) and "\n" not in str(error.value)


@pytest.mark.exclusive
def test_an_unreachable_scheduler_fails_within_ten_seconds_with_one_line():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{s.getsockname()[1]}"  # bound, not listening: nothing answers
        started = time.perf_counter()
        with pytest.raises(InputError, match="no Dask scheduler answered") as error:
            Executor(address=address)
    assert time.perf_counter() - started < 10
    assert address in str(error.value) and "tcp://host:8786" in str(error.value) and "\n" not in str(error.value)


@pytest.mark.exclusive
@pytest.mark.parametrize("argv", [
    ["enumerate", "--n", "2", "--out", "{tmp}/d.parquet"],
    ["teams", "nsga2", "--synthetic-seed", "0", "--regions", "3", "--pop", "4", "--generations", "1"],
    ["glso", "--budget", "1", "--method", "random", "--params", "{root}/profiles/default.yaml"],
])
def test_commands_with_an_unreachable_address_fail_within_ten_seconds(argv, tmp_path, cli_error):
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{s.getsockname()[1]}"
        started = time.perf_counter()
        cli_error([a.format(tmp=tmp_path, root=root) for a in argv] + ["--address", address],
                  f"no Dask scheduler answered at '{address}'")
    assert time.perf_counter() - started < 10


def _http_server():
    import http.server
    import threading

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.BaseHTTPRequestHandler)
    server.RequestHandlerClass.log_message = lambda *args: None  # no request lines on stderr
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


@pytest.mark.exclusive
@pytest.mark.slow
@pytest.mark.parametrize("listener", ["http server", "silent listener"])
def test_an_address_that_is_no_scheduler_fails_within_ten_seconds_with_one_line(listener):
    """An HTTP server held the Client ~5 minutes, a socket that accepts and never answers ~80 s."""
    server = silent = None
    if listener == "http server":
        server = _http_server()
        port = server.server_address[1]
    else:
        silent = socket.socket()
        silent.bind(("127.0.0.1", 0))
        silent.listen(8)
        port = silent.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    started = time.perf_counter()
    try:
        with pytest.raises(InputError, match="no Dask scheduler answered") as error:
            Executor(address=address)
    finally:
        if server is not None:
            server.shutdown()
            server.server_close()
        if silent is not None:
            silent.close()
    assert time.perf_counter() - started < 10
    assert repr(address) in str(error.value) and "within 5 s" in str(error.value) and "\n" not in str(error.value)


OWNER = """
import os, sys, time
from robocompose.fanout.executor import Executor

def busy(i):
    open(os.path.join(sys.argv[1], f"worker-{os.getpid()}"), "w").close()
    end = time.time() + 60
    while time.time() < end:  # computing, as a rollout batch does
        pass
    return i

if __name__ == "__main__":
    with Executor(workers=2) as executor:
        executor.map(busy, range(8))
"""


def _running(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rpartition(")")[2].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not os.path.isdir("/proc"), reason="reads process states from /proc")
def test_local_workers_stop_when_their_owner_is_killed(tmp_path):
    # SIGKILL runs no shutdown and the fork server outlives its owner: without the watch, both workers computed
    # the queued items on (measured: minutes at full load) and then waited forever.
    import subprocess
    import sys

    script = tmp_path / "owner.py"
    script.write_text(OWNER)
    owner = subprocess.Popen([sys.executable, str(script), str(tmp_path)], cwd=Path(__file__).parents[2])
    deadline = time.time() + 60
    while len(list(tmp_path.glob("worker-*"))) < 2 and time.time() < deadline:
        time.sleep(0.1)
    workers = [int(p.name.split("-")[1]) for p in tmp_path.glob("worker-*")]
    assert len(workers) == 2 and all(_running(pid) for pid in workers)
    owner.kill()
    owner.wait()
    deadline = time.time() + 10
    while any(_running(pid) for pid in workers) and time.time() < deadline:
        time.sleep(0.1)
    left = [pid for pid in workers if _running(pid)]
    for pid in left:  # a failing run must not leave them computing
        os.kill(pid, 9)
    assert left == []
