"""Prefect flow that runs the DVC pipeline: one task per DVC stage, each running `dvc repro <stage>`.

DVC keeps the stage graph and the cache (an up-to-date stage is skipped); Prefect adds schedules,
retries and logs. Stages run one at a time in dependency order, because DVC locks the repository
during `dvc repro`. A stage is retried only after a transient failure (see `transient`): a stage
that fails on its own inputs or code fails the same way again, so it fails the flow at once.

Run once, locally (Prefect starts a temporary local server; nothing to set up):

    python flows/pipeline.py                                # every stage
    python flows/pipeline.py --stage enumerate --stage bo   # some stages (+ what they need)

Serve it on a schedule against a real Prefect server:

    prefect server start --host 127.0.0.1
    PREFECT_API_URL=http://127.0.0.1:4200/api python flows/pipeline.py --serve --cron "0 3 * * *"
"""

from __future__ import annotations

import argparse
import graphlib
import os
import re
import signal
import subprocess
import sys
from collections import deque
from pathlib import Path

PROJECT_DIR = Path(__file__).resolve().parents[1]

# Prefect reads its settings when imported, so the defaults go in before the import below.
for _key, _value in {
    "PREFECT_HOME": str(PROJECT_DIR / ".prefect"),
    "PREFECT_SERVER_ANALYTICS_ENABLED": "false",
    "DO_NOT_TRACK": "1",  # telemetry otherwise races the server's migrations: "database is locked"
    "PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS": "120",  # first start migrates for ~20 s
    "DVC_NO_ANALYTICS": "1",
}.items():
    os.environ.setdefault(_key, _value)

from prefect import flow, get_run_logger, task  # noqa: E402
from prefect.settings import PREFECT_API_URL  # noqa: E402
from prefect.states import State  # noqa: E402

from robocompose.io.dispatch import pin_dispatch  # noqa: E402
from robocompose.io.errors import INPUT_ERROR_EXIT, InputError, error_line  # noqa: E402

_NODE = re.compile(r'^"(?P<node>[^"]+)";$')
_EDGE = re.compile(r'^"(?P<upstream>[^"]+)" -> "(?P<downstream>[^"]+)";$')
_LOG_TAIL = 20  # lines of dvc output quoted in the error of a failed stage
# dvc's last line when a stage's command failed: "... failed to run: CMD, exited with N" (N < 0: killed by signal -N).
_STAGE_EXIT = re.compile(r"^ERROR: failed to reproduce .*, exited with (?P<code>-?\d+)$")
# Signals that stop a healthy stage from outside: the OOM killer, a preempted or shut-down machine.
_KILLS = {signal.SIGKILL, signal.SIGTERM, signal.SIGHUP}
# The last line of a stage's traceback when the infrastructure under it failed, not its own code: a Dask worker
# lost, the connection to a scheduler dropped, a local worker process killed.
_INFRASTRUCTURE = re.compile(r"^(?:[\w.]+\.)?(?:KilledWorker|CommClosedError|BrokenProcessPool|BrokenPipeError"
                             r"|Connection(?:Refused|Reset|Aborted)?Error)(?::|$)")
_DVC_LOCKED = "Unable to acquire lock"  # another dvc process held the repository: try again later
SERVER_TIMEOUT = 5.0  # s to connect to and hear from the Prefect server's health check (one attempt, no retries)


def dvc_stages(project_dir: str | Path = ".") -> list[str]:
    """All stages of the DVC project in dependency order; matrix/foreach stages expanded (`bo@...`)."""
    # `python -m dvc` from this interpreter: the venv's dvc even when its bin/ is not on PATH.
    result = subprocess.run(
        [sys.executable, "-m", "dvc", "dag", "--dot"], cwd=project_dir, capture_output=True, text=True
    )
    if result.returncode:
        raise RuntimeError(f"`dvc dag --dot` failed in {project_dir}: {result.stderr.strip()}")
    graph: dict[str, set[str]] = {}
    for line in result.stdout.splitlines():
        if edge := _EDGE.match(line.strip()):
            graph.setdefault(edge["downstream"], set()).add(edge["upstream"])
        elif node := _NODE.match(line.strip()):
            graph.setdefault(node["node"], set())
    return list(graphlib.TopologicalSorter(graph).static_order())


def select_stages(all_stages: list[str], wanted: list[str] | None) -> list[str]:
    """The stages of `all_stages` named in `wanted` (a matrix stage's name selects all its items).

    Keeps dependency order; `wanted=None` selects everything.
    """
    if wanted is None:
        return list(all_stages)
    unknown = [w for w in wanted if not any(s == w or s.startswith(f"{w}@") for s in all_stages)]
    if unknown:
        raise ValueError(f"unknown DVC stage(s) {unknown}; dvc.yaml defines {all_stages}")
    return [s for s in all_stages if any(s == w or s.startswith(f"{w}@") for w in wanted)]


class StageFailed(RuntimeError):
    """A `dvc repro` that exited non-zero; `transient` if running it again may succeed."""

    def __init__(self, message: str, transient: bool):
        super().__init__(message)
        self.transient = transient


def transient(returncode: int, output: list[str]) -> bool:
    """Whether a `dvc repro` that exited `returncode` with `output` (its last lines) failed for a passing reason.

    Transient: dvc or the stage killed from outside (SIGKILL, SIGTERM, SIGHUP, also as a shell's 128 + n), the
    repository locked by another dvc, or a stage whose traceback ends in a lost worker or connection. Not
    transient: a stage's own failure (exit 2 for bad params or inputs, 1 for an exception in its code, Ctrl-C).
    """
    if returncode < 0:
        return -returncode in _KILLS
    if any(_DVC_LOCKED in line for line in output):
        return True
    for i, line in enumerate(output):
        if stage_exit := _STAGE_EXIT.match(line):
            code = int(stage_exit["code"])
            if -code in _KILLS or code - 128 in _KILLS:
                return True
            return i > 0 and bool(_INFRASTRUCTURE.match(output[i - 1]))
    return False


def retry_if_transient(task: object, task_run: object, state: State) -> bool:
    """Prefect's `retry_condition_fn` of `run_stage`: retry a StageFailed only if transient; an OSError (the
    subprocess could not start: no memory, too many open files) always; any other exception never."""
    error = state.result(raise_on_failure=False)
    if isinstance(error, StageFailed):
        return error.transient
    return isinstance(error, OSError)


@task(task_run_name="dvc repro {stage}", retries=1, retry_delay_seconds=5, retry_condition_fn=retry_if_transient)
def run_stage(stage: str, project_dir: str) -> None:
    """`dvc repro <stage>` in the project, its output streamed into the Prefect log."""
    logger = get_run_logger()
    command = [sys.executable, "-m", "dvc", "repro", stage]
    tail: deque[str] = deque(maxlen=_LOG_TAIL)
    with subprocess.Popen(
        command, cwd=project_dir, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    ) as process:
        assert process.stdout is not None
        for line in process.stdout:
            if line := line.rstrip():
                logger.info(line)
                tail.append(line)
    if process.returncode:
        output = "\n".join(tail)
        raise StageFailed(f"DVC stage {stage!r} failed (dvc repro exited {process.returncode}):\n{output}",
                          transient(process.returncode, list(tail)))


@flow(name="robocompose-pipeline")
def pipeline(stages: list[str] | None = None, project_dir: str = ".") -> list[str]:
    """Reproduce the DVC stages `stages` (all if None) of the project in dependency order.

    Returns the stages run; the first stage that fails (after its retry, if the failure was transient) fails the
    flow.
    """
    selected = select_stages(dvc_stages(project_dir), stages)
    get_run_logger().info("stages: %s", selected)
    for stage in selected:
        run_stage(stage, project_dir)
    return selected


def cron_expression(text: str) -> str:
    """argparse type of a schedule: checked by Prefect's own CronSchedule (croniter, no random/hashed fields)."""
    from prefect.client.schemas.schedules import CronSchedule
    from pydantic import ValidationError

    try:
        return CronSchedule(cron=text).cron
    except ValidationError as err:
        reason = err.errors()[0]["msg"].removeprefix("Value error, ")
        raise argparse.ArgumentTypeError(f"{reason}; expected 5 fields: minute hour day-of-month month "
                                         "day-of-week, e.g. '0 3 * * *'") from None


def check_server(url: str, timeout: float = SERVER_TIMEOUT) -> None:
    """InputError naming `url` unless the Prefect API there answers its health check within `timeout` seconds.

    Prefect's own client retries an unreachable server for minutes; this asks once, with a deadline.
    """
    import httpx

    try:
        response = httpx.get(f"{url.rstrip('/')}/health", timeout=timeout)
        response.raise_for_status()
    except (httpx.HTTPError, httpx.InvalidURL) as err:
        reason = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise InputError(f"PREFECT_API_URL {url!r}: no answer to the health check ({reason}; waited at most "
                         f"{timeout:g} s per step), expected a running Prefect server (`prefect server start`)"
                         ) from None


def main(argv: list[str] | None = None) -> int:
    """Command line: run the flow once, or serve it on a cron schedule."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--stage", action="append", dest="stages", help="stage to run (repeatable)")
    parser.add_argument("--project-dir", default=str(PROJECT_DIR), help="DVC project (default: %(default)s)")
    parser.add_argument("--serve", action="store_true", help="serve on a schedule (needs a Prefect server)")
    parser.add_argument("--cron", type=cron_expression, default="0 3 * * *",
                        help="schedule for --serve (default: %(default)s)")
    parser.add_argument("--name", default="scheduled", help="deployment name for --serve")
    args = parser.parse_args(argv)
    try:  # check the stage names against dvc.yaml before any Prefect server starts
        select_stages(dvc_stages(args.project_dir), args.stages)
    except (ValueError, RuntimeError) as err:
        parser.error(str(err))
    parameters = {"stages": args.stages, "project_dir": args.project_dir}
    if args.serve:
        if not PREFECT_API_URL.value():
            parser.error("--serve needs a Prefect server: set PREFECT_API_URL (see the commands above)")
        try:
            check_server(PREFECT_API_URL.value())
        except InputError as err:
            print(error_line(parser.prog, err), file=sys.stderr)
            return INPUT_ERROR_EXIT
        pipeline.serve(name=args.name, cron=args.cron, parameters=parameters)
        return 0
    state = pipeline(**parameters, return_state=True)
    return 0 if state.is_completed() else 1


if __name__ == "__main__":
    pin_dispatch()  # before the stages start: they inherit it (and need not re-execute themselves)
    sys.exit(main())
