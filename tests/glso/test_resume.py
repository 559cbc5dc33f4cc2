"""Kill/resume equality: a run stopped at any step resumes from its checkpoint and ends with the same table."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from robocompose.evaluation.evaluate import EvaluationConfig
from robocompose.glso.runs import RunSpec, run_search
from tests.glso.conftest import fake_objective

EVALUATION = EvaluationConfig()
ROOT = Path(__file__).resolve().parents[2]


def saved_rows(checkpoint: Path) -> list:
    """The rows of a run's checkpoint (its header line, then the rows as JSON)."""
    return json.loads(checkpoint.read_bytes().split(b"\n", 1)[1])


class Killed(Exception):
    pass


def stop_at(step: int):
    def on_step(row: dict) -> None:
        if row["step"] == step:
            raise Killed
    return on_step


@pytest.mark.parametrize("method, kill_at", [("glso", 4), ("glso", 7), ("mcts", 3), ("ghs", 2), ("ghs", 6),
                                             ("ga", 5)])
def test_a_stopped_run_resumes_to_the_same_table(method, kill_at, small_config, tmp_path):
    spec = RunSpec("flat", method, 0)
    whole = run_search(spec, small_config, EVALUATION, objective_fn=fake_objective)
    checkpoint = tmp_path / "run.ckpt"
    with pytest.raises(Killed):
        run_search(spec, small_config, EVALUATION, objective_fn=fake_objective, checkpoint=checkpoint,
                   on_step=stop_at(kill_at))
    assert len(saved_rows(checkpoint)) == kill_at + 1
    resumed = run_search(spec, small_config, EVALUATION, objective_fn=fake_objective, checkpoint=checkpoint)
    assert resumed.equals(whole)


def test_a_checkpoint_of_other_settings_is_started_over(small_config, tmp_path):
    import dataclasses

    spec, checkpoint = RunSpec("flat", "mcts", 0), tmp_path / "run.ckpt"
    run_search(spec, small_config, EVALUATION, objective_fn=fake_objective, checkpoint=checkpoint)
    other = dataclasses.replace(small_config, mcts=dataclasses.replace(small_config.mcts, amaf_threshold=3.0))
    resumed = run_search(spec, other, EVALUATION, objective_fn=fake_objective, checkpoint=checkpoint)
    fresh = run_search(spec, other, EVALUATION, objective_fn=fake_objective)
    assert resumed.equals(fresh)


SCRIPT = """
import time
from pathlib import Path
from robocompose.evaluation.evaluate import EvaluationConfig
from robocompose.glso.runs import GLSOConfig, RunSpec, run_search
from robocompose.params import build_config
from tests.glso.conftest import fake_objective

def slow(tree):
    time.sleep(0.3)
    return fake_objective(tree)

config = build_config(GLSOConfig, {{"tasks": ["flat"], "seeds": [0], "budget": 9, "models": {models!r},
                                    "bo": {{"init": 3}}, "ga": {{"population": 4}},
                                    "ghs": {{"num_samples": 3, "opt_iter": 2, "eps_end": 0.5,
                                            "eps_sample_end": 0.5}}}}, "glso")
run_search(RunSpec("flat", {method!r}, 0), config, EvaluationConfig(), objective_fn=slow,
           checkpoint=Path({checkpoint!r}))
"""


@pytest.mark.parametrize("method", ["glso", "mcts", "ghs"])
def test_a_killed_process_resumes_to_the_same_table(method, small_config, tmp_path):
    checkpoint = tmp_path / "run.ckpt"
    script = textwrap.dedent(SCRIPT.format(models=small_config.models, method=method, checkpoint=str(checkpoint)))
    process = subprocess.Popen([sys.executable, "-c", script], cwd=ROOT,
                               env={**os.environ, "PYTHONPATH": str(ROOT)}, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:  # kill it mid-run: after >= 3 checkpointed steps
            if checkpoint.exists() and len(saved_rows(checkpoint)) >= 3:
                break
            time.sleep(0.05)
        os.kill(process.pid, signal.SIGKILL)
    finally:
        process.wait()
    done = len(saved_rows(checkpoint))
    assert 3 <= done < small_config.budget
    resumed = run_search(RunSpec("flat", method, 0), small_config, EVALUATION, objective_fn=fake_objective,
                         checkpoint=checkpoint)
    whole = run_search(RunSpec("flat", method, 0), small_config, EVALUATION, objective_fn=fake_objective)
    assert resumed.equals(whole)
