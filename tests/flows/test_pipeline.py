"""The Prefect pipeline flow on real, tiny DVC projects: against a temporary Prefect server, and served on a
cron schedule against a real `prefect server` on loopback (the run triggered through its API)."""

from __future__ import annotations

import asyncio
import importlib.util
import json
import os
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:  # prefect is imported only once the fixture has pointed it at a temporary home
    from prefect.states import State

PIPELINE_FILE = Path(__file__).resolve().parents[2] / "flows" / "pipeline.py"

# Stage `a` writes a file from params (`${n}` is params.yaml's n), matrix stage `b` one file per item
# from it, and `c` one from b@x.
DVC_YAML = """\
stages:
  a:
    cmd: python -c "open('a.txt', 'w').write('${n}')"
    params: [n]
    outs: [a.txt]
  b:
    matrix:
      suffix: [x, y]
    cmd: python -c "open('b_${item.suffix}.txt', 'w').write(open('a.txt').read() + '${item.suffix}')"
    deps: [a.txt]
    outs: ["b_${item.suffix}.txt"]
  c:
    cmd: python -c "open('c.txt', 'w').write(open('b_x.txt').read() + 'c')"
    deps: [b_x.txt]
    outs: [c.txt]
"""

# Stage `b` leaves a line in attempts.txt on every attempt (not a DVC output: it survives), then fails.
FAILING_DVC_YAML = """\
stages:
  a:
    cmd: python -c "open('a.txt', 'w').write('7')"
    outs: [a.txt]
  b:
    cmd: python -c "open('attempts.txt', 'a').write('attempt\\n'); raise SystemExit(3)"
    deps: [a.txt]
    outs: [b.txt]
  c:
    cmd: python -c "open('c.txt', 'w').write(open('b.txt').read())"
    deps: [b.txt]
    outs: [c.txt]
"""


def make_dvc_project(root: Path, dvc_yaml: str = DVC_YAML) -> Path:
    """A fresh git + DVC project (analytics off) with `dvc_yaml` and params n: 7."""
    root.mkdir(parents=True)
    (root / "dvc.yaml").write_text(dvc_yaml)
    (root / "params.yaml").write_text("n: 7\n")
    for command in (
        ["git", "init", "-q"],
        [sys.executable, "-m", "dvc", "init", "-q"],
        [sys.executable, "-m", "dvc", "config", "core.analytics", "false"],
        [sys.executable, "-m", "dvc", "config", "core.check_update", "false"],
    ):
        subprocess.run(command, cwd=root, check=True, capture_output=True)
    return root


def dvc_status(project: Path) -> dict:
    result = subprocess.run(
        [sys.executable, "-m", "dvc", "status", "--json"],
        cwd=project,
        check=True,
        capture_output=True,
        text=True,
    )
    return json.loads(result.stdout)


@pytest.fixture(scope="module")
def flows_pipeline(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ModuleType]:
    """flows/pipeline.py imported with Prefect pointed at a temporary home and server."""
    tmp = tmp_path_factory.mktemp("prefect")
    with pytest.MonkeyPatch.context() as env:
        # All the defaults the module would set, so none of them outlives these tests.
        env.setenv("PREFECT_HOME", str(tmp / "home"))
        env.setenv("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
        env.setenv("DO_NOT_TRACK", "1")
        env.setenv("PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS", "120")
        env.setenv("DVC_NO_ANALYTICS", "1")
        env.setenv("DVC_SITE_CACHE_DIR", str(tmp / "dvc_site_cache"))
        spec = importlib.util.spec_from_file_location("flows_pipeline", PIPELINE_FILE)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)

        from prefect.settings import PREFECT_HOME, temporary_settings
        from prefect.testing.utilities import prefect_test_harness

        # The env var only counts if prefect was not imported yet; the setting always does.
        with temporary_settings(updates={PREFECT_HOME: tmp / "home"}), prefect_test_harness(120):
            yield module


def run_pipeline(flows_pipeline: ModuleType, project_dir: Path, stages: list[str] | None = None) -> State:
    """Run the pipeline flow on `project_dir`; return its final Prefect state (never raises)."""
    return flows_pipeline.pipeline(stages=stages, project_dir=str(project_dir), return_state=True)


def test_stage_order_follows_the_dag(flows_pipeline: ModuleType, tmp_path: Path) -> None:
    project = make_dvc_project(tmp_path / "project")
    order = flows_pipeline.dvc_stages(project)
    assert sorted(order) == ["a", "b@x", "b@y", "c"]
    assert order.index("a") < order.index("b@x") < order.index("c") and order.index("a") < order.index("b@y")
    assert flows_pipeline.select_stages(order, ["c", "b"]) == [s for s in order if s != "a"]
    with pytest.raises(ValueError, match=r"unknown DVC stage\(s\) \['d'\]"):
        flows_pipeline.select_stages(order, ["d"])


def test_pipeline_reproduces_selected_then_all_stages(flows_pipeline: ModuleType, tmp_path: Path) -> None:
    project = make_dvc_project(tmp_path / "project")
    # From the command line, a matrix stage's name selects its items; DVC brings in what they need.
    assert flows_pipeline.main(["--stage", "b", "--project-dir", str(project)]) == 0
    assert (project / "b_x.txt").read_text() == "7x" and (project / "b_y.txt").read_text() == "7y"
    assert not (project / "c.txt").exists()

    state = run_pipeline(flows_pipeline, project)
    assert state.is_completed(), state.message
    assert sorted(state.result()) == ["a", "b@x", "b@y", "c"]
    assert (project / "a.txt").read_text() == "7"
    assert (project / "c.txt").read_text() == "7xc"
    assert dvc_status(project) == {}


FLAKY_DVC_YAML = """\
stages:
  a:
    cmd: python -c "open('a.txt', 'w').write('7'); print('stage a wrote 7')"
    outs: [a.txt]
  b:
    cmd: python flaky.py
    deps: [a.txt]
    outs: [b.txt]
"""

# Stage `b` of FLAKY_DVC_YAML killed by SIGKILL (as the OOM killer would) on its first attempt, then it succeeds.
KILLED_ONCE_STAGE = """\
import os, signal
if not os.path.exists("tried"):
    open("tried", "w").close()
    os.kill(os.getpid(), signal.SIGKILL)
open("b.txt", "w").write(open("a.txt").read() + "b")
"""


def test_a_deterministic_failure_runs_once_and_fails_the_flow(
    flows_pipeline: ModuleType, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    task = flows_pipeline.run_stage
    assert (task.retries, task.retry_delay_seconds) == (1, 5)
    assert task.retry_condition_fn is flows_pipeline.retry_if_transient
    # Same task without the 5 s wait before a retry, to keep the test fast (a wrong retry would still show).
    monkeypatch.setattr(flows_pipeline, "run_stage", task.with_options(retry_delay_seconds=0))
    project = make_dvc_project(tmp_path / "project", FAILING_DVC_YAML)
    state = run_pipeline(flows_pipeline, project)
    assert state.is_failed()
    assert "DVC stage 'b' failed" in state.message
    assert (project / "a.txt").read_text() == "7"  # the stage before ran
    assert (project / "attempts.txt").read_text() == "attempt\n"  # exit 3: its own failure, not retried
    assert not (project / "c.txt").exists()  # the stage after did not


def test_a_killed_stage_is_retried(flows_pipeline: ModuleType, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(flows_pipeline, "run_stage", flows_pipeline.run_stage.with_options(retry_delay_seconds=0))
    project = make_dvc_project(tmp_path / "project", FLAKY_DVC_YAML)
    (project / "flaky.py").write_text(KILLED_ONCE_STAGE)
    state = run_pipeline(flows_pipeline, project)
    assert state.is_completed(), state.message
    assert (project / "tried").exists() and (project / "b.txt").read_text() == "7b"


def _dvc_failure(stage_exit: int, before: str = "some output") -> list[str]:
    return [before, f"ERROR: failed to reproduce 'b': failed to run: python b.py, exited with {stage_exit}"]


@pytest.mark.parametrize(("returncode", "output", "expected"), [
    (255, _dvc_failure(2, "stage b: error: params.yaml: b: n must be a positive integer, got -3"), False),
    (255, _dvc_failure(1, "ValueError: x"), False),  # an exception in the stage's code
    (255, _dvc_failure(130, "stage b: interrupted"), False),  # Ctrl-C: the user stopped it
    (255, _dvc_failure(3), False),
    (255, _dvc_failure(-9), True),  # SIGKILL: the OOM killer
    (255, _dvc_failure(-15), True),  # SIGTERM: a machine shutting down
    (255, _dvc_failure(137), True),  # SIGKILL as a shell reports it
    (255, _dvc_failure(1, "distributed.scheduler.KilledWorker: Attempted to run task 'x' on 3 different workers"),
     True),
    (255, _dvc_failure(1, "ConnectionRefusedError: [Errno 111] Connection refused"), True),
    (255, _dvc_failure(1, "concurrent.futures.process.BrokenProcessPool: A process in the pool was terminated"),
     True),
    (255, ["ERROR: Unable to acquire lock. Most likely another DVC process is running"], True),
    (-9, ["Running stage 'b':"], True),  # dvc itself killed
    (-2, ["Running stage 'b':"], False),
])
def test_only_transient_failures_count_as_transient(flows_pipeline: ModuleType, returncode: int, output: list[str],
                                                   expected: bool) -> None:
    assert flows_pipeline.transient(returncode, output) is expected


TINY_PARAMS = {"compute": {"workers": 2}, "enumerate": {"n": 6, "seed": 0, "chunk": 8}, "nogram": {"n": 4, "seed": 1}}


def dvc(project: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "dvc", *args], cwd=project, capture_output=True, text=True)


def test_flow_runs_the_real_enumerate_stage_reproducibly(
    flows_pipeline: ModuleType, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, copy_project
) -> None:
    import os

    monkeypatch.setenv("PATH", f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")  # the stages' python
    project = copy_project(tmp_path / "project", TINY_PARAMS)
    state = run_pipeline(flows_pipeline, project, stages=["enumerate"])
    assert state.is_completed(), state.message
    designs = project / "data" / "designs.parquet"
    first = designs.read_bytes()
    from robocompose.io import read_table

    assert len(read_table(designs, "designs")) == 6
    assert len(read_table(project / "data" / "designs_nogram.parquet", "designs")) == 4

    again = dvc(project, "repro", "enumerate")
    assert again.returncode == 0 and "didn't change" in again.stdout  # a no-op right after

    designs.unlink()
    assert dvc(project, "repro", "enumerate").returncode == 0
    assert designs.read_bytes() == first  # deleted and re-run: the same bytes

    params = yaml_load(project / "params.yaml")
    params["enumerate"]["n"] = -3
    (project / "params.yaml").write_text(yaml_dump(params))
    failed = dvc(project, "repro", "enumerate")
    assert failed.returncode != 0
    assert "params.yaml: enumerate: n must be a positive integer, got -3" in failed.stderr + failed.stdout
    leftovers = [p.name for p in (project / "data").iterdir()]
    assert "designs.parquet" not in leftovers and not [p for p in leftovers if p.startswith(".")]


def yaml_load(path: Path) -> dict:
    import yaml

    return yaml.safe_load(path.read_text())


def yaml_dump(document: dict) -> str:
    import yaml

    return yaml.safe_dump(document)


def test_unknown_stage_is_rejected_before_any_prefect_server_starts(tmp_path: Path) -> None:
    project = make_dvc_project(tmp_path / "project")
    home = tmp_path / "prefect_home"
    env = {**os.environ, "PREFECT_HOME": str(home), "PREFECT_API_URL": "", "DVC_NO_ANALYTICS": "1",
           "DVC_SITE_CACHE_DIR": str(tmp_path / "dvc_site_cache")}
    result = subprocess.run([sys.executable, str(PIPELINE_FILE), "--stage", "nosuch", "--project-dir", str(project)],
                            capture_output=True, text=True, env=env)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "error: unknown DVC stage(s) ['nosuch']; dvc.yaml defines" in result.stderr.splitlines()[-1]
    assert not list(home.rglob("*.db"))  # the ephemeral server's database: never created
def _serve(project: Path, tmp_path: Path, api_url: str, *flags: str) -> tuple[subprocess.CompletedProcess, float]:
    """`pipeline.py --serve` against `api_url` with its own Prefect home; (result, seconds it took)."""
    env = {**os.environ, "PREFECT_HOME": str(tmp_path / "prefect_home"), "PREFECT_API_URL": api_url,
           "DVC_NO_ANALYTICS": "1", "DVC_SITE_CACHE_DIR": str(tmp_path / "dvc_site_cache")}
    started = time.monotonic()
    result = subprocess.run([sys.executable, str(PIPELINE_FILE), "--serve", "--project-dir", str(project), *flags],
                            capture_output=True, text=True, env=env, timeout=60)
    return result, time.monotonic() - started


@pytest.mark.parametrize(("cron", "reason"), [("bad cron", 'Invalid cron string: "bad cron"'),
                                              ("61 3 * * *", "Invalid cron string"),
                                              ("H 3 * * *", "Invalid cron string")])
def test_a_bad_cron_is_rejected_before_any_server_is_contacted(tmp_path: Path, cron: str, reason: str) -> None:
    with socket.socket() as listener:  # a server that would see a connection if the flow tried one
        listener.bind(("127.0.0.1", 0))
        listener.listen()
        listener.settimeout(0)
        result, _ = _serve(tmp_path, tmp_path, f"http://127.0.0.1:{listener.getsockname()[1]}/api", "--cron", cron)
        with pytest.raises(BlockingIOError):
            listener.accept()
    assert result.returncode == 2 and "Traceback" not in result.stderr
    line = result.stderr.splitlines()[-1]
    assert line.startswith(f"pipeline.py: error: argument --cron: {reason}")
    assert line.endswith("expected 5 fields: minute hour day-of-month month day-of-week, e.g. '0 3 * * *'")


@pytest.mark.exclusive
def test_an_unreachable_server_fails_in_one_line_within_seconds(tmp_path: Path) -> None:
    project = make_dvc_project(tmp_path / "project")
    url = f"http://127.0.0.1:{_free_port()}/api"  # nothing listens there: refused
    result, seconds = _serve(project, tmp_path, url)
    assert result.returncode == 2 and "Traceback" not in result.stderr and seconds < 10
    assert result.stderr.strip().splitlines() == [
        f"pipeline.py: error: PREFECT_API_URL '{url}': no answer to the health check ([Errno 111] Connection refused; "
        "waited at most 5 s per step), expected a running Prefect server (`prefect server start`)"]


@pytest.mark.exclusive
def test_a_server_that_never_answers_fails_within_the_deadline(tmp_path: Path) -> None:
    project = make_dvc_project(tmp_path / "project")
    with socket.socket() as silent:  # accepts connections (the kernel's backlog), never replies
        silent.bind(("127.0.0.1", 0))
        silent.listen()
        url = f"http://127.0.0.1:{silent.getsockname()[1]}/api"
        result, seconds = _serve(project, tmp_path, url)
    assert result.returncode == 2 and "Traceback" not in result.stderr and seconds < 15
    line, = result.stderr.strip().splitlines()
    assert line.startswith(f"pipeline.py: error: PREFECT_API_URL '{url}': no answer to the health check (")
    assert not list((tmp_path / "prefect_home").rglob("*.db"))


# --- served on a real Prefect server ---


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _wait_healthy(url: str, server: subprocess.Popen, seconds: float = 180) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        assert server.poll() is None, "prefect server exited during start-up"
        try:
            with urllib.request.urlopen(f"{url}/health", timeout=2) as response:
                if response.status == 200:
                    return
        except OSError:
            time.sleep(1)
    raise AssertionError(f"prefect server at {url} not healthy after {seconds} s")


@pytest.fixture()
def prefect_server(tmp_path: Path):
    """A real Prefect server on 127.0.0.1 with its own home; yields the env that points clients at it."""
    port = _free_port()
    env = {**os.environ, "PREFECT_HOME": str(tmp_path / "prefect"), "PREFECT_SERVER_ANALYTICS_ENABLED": "false",
           "DO_NOT_TRACK": "1", "DVC_NO_ANALYTICS": "1", "PREFECT_RUNNER_POLL_FREQUENCY": "1",
           "PREFECT_API_URL": f"http://127.0.0.1:{port}/api",
           "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    server = subprocess.Popen([sys.executable, "-m", "prefect", "server", "start", "--host", "127.0.0.1",
                               "--port", str(port)], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        _wait_healthy(env["PREFECT_API_URL"], server)
        yield env
    finally:
        server.terminate()
        server.wait(timeout=30)


@pytest.mark.slow
@pytest.mark.timeout(1200)  # a busy machine: the server starts in ~20 s idle, minutes under load
def test_served_flow_runs_on_a_real_server_and_retries_a_failed_stage(prefect_server: dict, tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    project = make_dvc_project(tmp_path / "project", FLAKY_DVC_YAML)
    (project / "flaky.py").write_text(KILLED_ONCE_STAGE)
    serve = subprocess.Popen([sys.executable, str(PIPELINE_FILE), "--serve", "--cron", "0 3 * * *", "--name",
                              "nightly", "--project-dir", str(project)], env=prefect_server,
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    for key, value in prefect_server.items():
        monkeypatch.setenv(key, value)
    try:
        state, logs, schedules = asyncio.run(_trigger_and_wait(serve))
    finally:
        serve.terminate()
        output = serve.communicate(timeout=30)[0]
    assert state.is_completed(), f"{state.name}: {state.message}\n{output[-3000:]}"
    assert [s for s in schedules if "0 3 * * *" in s], schedules
    assert (project / "b.txt").read_text() == "7b" and (project / "tried").exists()
    assert any("stage a wrote 7" in line for line in logs)
    assert any("DVC stage 'b' failed" in line and "Retry 1/1" in line for line in logs), logs  # failed once


async def _trigger_and_wait(serve: subprocess.Popen, seconds: float = 540):
    from prefect.client.orchestration import get_client

    deadline = time.monotonic() + seconds
    async with get_client() as client:
        deployment = None
        while deployment is None:
            assert serve.poll() is None, serve.stdout.read()
            assert time.monotonic() < deadline, "the served deployment never appeared"
            try:
                deployment = await client.read_deployment_by_name("robocompose-pipeline/nightly")
            except Exception:  # not registered yet (ObjectNotFound): the serve process is starting
                await asyncio.sleep(1)
        schedules = [str(s.schedule) for s in deployment.schedules]
        run = await client.create_flow_run_from_deployment(deployment.id)
        while True:
            run = await client.read_flow_run(run.id)
            if run.state is not None and run.state.is_final():
                break
            assert time.monotonic() < deadline, f"flow run still {run.state.name if run.state else None}"
            await asyncio.sleep(1)
        from prefect.client.schemas.filters import LogFilter, LogFilterFlowRunId

        logs = await client.read_logs(LogFilter(flow_run_id=LogFilterFlowRunId(any_=[run.id])))
        return run.state, [log.message for log in logs], schedules
