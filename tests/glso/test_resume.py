"""Kill/resume equality: a run stopped at any step resumes from its checkpoint and ends with the same table."""

import contextlib
import json
import os
import random
import signal
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch

from robocompose.evaluation.evaluate import EvaluationConfig
from robocompose.glso.registry import METHODS
from robocompose.glso.runs import RunSpec, run_key, run_search
from robocompose.io import InputError
from robocompose.io.checkpoint import save_checkpoint
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


@contextlib.contextmanager
def global_rngs_seeded(seed: int):
    """Python's, NumPy's and torch's global generators seeded with `seed`, restored afterwards."""
    python, legacy = random.getstate(), np.random.get_state()
    with torch.random.fork_rng():
        random.seed(seed)
        np.random.seed(seed)
        torch.manual_seed(seed)
        try:
            yield
        finally:
            random.setstate(python)
            np.random.set_state(legacy)


# Every registered method, stopped after its random start and across its own boundaries: GLSO's init 3 (the
# replay fits the GP again; the trust-region BO's too, its Thompson draws seeded per step), the GA's generations of
# population 4, GHS's and MCTS's growing networks and trees.
CASES = [("glso", 4), ("glso", 7), ("glso_nopred", 5), ("glso_nogram", 5), ("random", 3), ("ga", 5), ("ga", 7),
         ("mcts", 3), ("ghs", 2), ("ghs", 6), ("glso_nodr", 5), ("glso_floor", 5), ("glso_reask", 5),
         ("glso_reask", 7), ("glso_thesis", 5), ("glso_turbo", 4), ("glso_turbo", 7), ("glso_turbo_thesis", 4),
         ("glso_nopred_turbo_thesis", 5)]


def test_every_registered_method_has_a_resume_case():
    assert {method for method, _ in CASES} == set(METHODS)


@pytest.mark.parametrize("method, kill_at", [  # GHS replays its own searches (~15 s a case): in `make test-slow`
    pytest.param(*case, marks=[pytest.mark.slow] if case[0] == "ghs" else []) for case in CASES])
def test_a_stopped_run_resumes_by_replay_to_the_same_table(method, kill_at, small_config, tmp_path):
    """kill_at + 1 steps with a checkpoint, then the rest of the budget from it: the same step table, row for row
    and byte for byte, as an uninterrupted run, and no objective call for the replayed steps. The global RNGs
    differ between the runs, so a method that drew from them (which replay cannot reproduce) would diverge."""
    spec, checkpoint = RunSpec("flat", method, 0), tmp_path / "run.ckpt"
    with global_rngs_seeded(1):
        whole = run_search(spec, small_config, EVALUATION, objective_fn=fake_objective, table=tmp_path / "whole.pq")
    with global_rngs_seeded(2), pytest.raises(Killed):
        run_search(spec, small_config, EVALUATION, objective_fn=fake_objective, checkpoint=checkpoint,
                   on_step=stop_at(kill_at))
    assert len(saved_rows(checkpoint)) == kill_at + 1
    calls = []

    def counted(tree):
        calls.append(tree.design_id)
        return fake_objective(tree)

    with global_rngs_seeded(3):
        resumed = run_search(spec, small_config, EVALUATION, objective_fn=counted, checkpoint=checkpoint,
                             table=tmp_path / "resumed.pq")
    assert calls == list(whole["design_id"][kill_at + 1:])  # the recorded steps cost no call
    assert resumed.equals(whole)
    assert (tmp_path / "resumed.pq").read_bytes() == (tmp_path / "whole.pq").read_bytes()
    assert pd.DataFrame(saved_rows(checkpoint)).equals(whole)  # the checkpoint holds every row, as plain data


@pytest.mark.parametrize("tamper, reason", [
    ("design", "step 2 recorded design not-this-design, replaying it proposes "),
    ("score", "step 2 is not a step row of this run"),
    ("nan_score", "step 2 is not a step row of this run"),
    ("column", "step 2 is not a step row of this run"),
    ("too_long", "not a list of at most 9 step rows"),
])
def test_a_checkpoint_the_replay_does_not_reproduce_is_refused_when_named_else_started_over(
        tamper, reason, small_config, tmp_path):
    """Rows of this run's key that the method does not propose again (other code, an edited file): the run the
    user named it for stops with one line naming the file and the step, the project's own run warns one line
    and starts afresh (overwriting the checkpoint)."""
    spec, checkpoint = RunSpec("flat", "mcts", 0), tmp_path / "run.ckpt"
    with pytest.raises(Killed):
        run_search(spec, small_config, EVALUATION, objective_fn=fake_objective, checkpoint=checkpoint,
                   on_step=stop_at(4))
    rows = saved_rows(checkpoint)
    if tamper == "design":
        rows[2]["design_id"] = "not-this-design"
    elif tamper == "score":
        rows[2]["score"] = "4.5"
    elif tamper == "nan_score":
        rows[2]["score"] = float("nan")
    elif tamper == "column":
        del rows[2]["best_so_far"]
    else:
        rows = rows * 2
    save_checkpoint(checkpoint, run_key(spec, small_config, EVALUATION, None), rows, kind="json")  # the right key
    with pytest.raises(InputError) as error:
        run_search(spec, small_config, EVALUATION, objective_fn=lambda tree: pytest.fail("evaluated"),
                   checkpoint=checkpoint, named_checkpoint=True)
    assert str(error.value).startswith(f"{checkpoint}: {reason}") and "\n" not in str(error.value)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        resumed = run_search(spec, small_config, EVALUATION, objective_fn=fake_objective, checkpoint=checkpoint)
    assert [str(w.message) for w in caught if "starting afresh" in str(w.message)] == [
        str(w.message) for w in caught]
    assert len(caught) == 1 and str(caught[0].message).startswith(f"{checkpoint}: {reason}")
    assert resumed.equals(run_search(spec, small_config, EVALUATION, objective_fn=fake_objective))
    assert len(saved_rows(checkpoint)) == small_config.budget  # the fresh run's


def test_a_checkpoint_of_other_settings_is_started_over(small_config, tmp_path):
    import dataclasses

    spec, checkpoint = RunSpec("flat", "mcts", 0), tmp_path / "run.ckpt"
    run_search(spec, small_config, EVALUATION, objective_fn=fake_objective, checkpoint=checkpoint)
    other = dataclasses.replace(small_config, mcts=dataclasses.replace(small_config.mcts, amaf_threshold=3.0))
    resumed = run_search(spec, other, EVALUATION, objective_fn=fake_objective, checkpoint=checkpoint)
    fresh = run_search(spec, other, EVALUATION, objective_fn=fake_objective)
    assert resumed.equals(fresh)


def test_a_checkpoint_made_at_one_rung_is_started_over_at_another(small_config, tmp_path):
    """glso.rung changes the runs' evaluator, and with it the checkpoint key: a run at another rung replays
    nothing of the checkpoint and spends its whole budget again; at the same rung it resumes without a call."""
    import dataclasses

    spec, checkpoint = RunSpec("flat", "random", 0), tmp_path / "run.ckpt"
    calls = []

    def counted(tree) -> dict:
        calls.append(tree.design_id)
        return fake_objective(tree)

    cheap = dataclasses.replace(small_config, rung="s8_h8_e48")
    first = run_search(spec, cheap, cheap.evaluator(EVALUATION), objective_fn=counted, checkpoint=checkpoint)
    assert len(calls) == cheap.budget
    again = run_search(spec, cheap, cheap.evaluator(EVALUATION), objective_fn=counted, checkpoint=checkpoint)
    assert again.equals(first) and len(calls) == cheap.budget  # resumed: no call
    other = dataclasses.replace(small_config, rung="s16_h8_e48")
    with pytest.warns(UserWarning, match="a checkpoint of another run or other code"):
        run_search(spec, other, other.evaluator(EVALUATION), objective_fn=counted, checkpoint=checkpoint)
    assert len(calls) == 2 * cheap.budget


SCRIPT = """
import time
import warnings
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
