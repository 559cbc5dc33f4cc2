import dataclasses
import json

import pytest

from robocompose.cli import main


@pytest.fixture
def params(tmp_path, tiny_models):
    import yaml

    from robocompose.io.provenance import ROOT
    from robocompose.params import merge, read_params

    path = tmp_path / "params.yaml"  # every section (a missing one is an error), these knobs changed
    path.write_text(yaml.safe_dump(merge(read_params(ROOT / "profiles" / "default.yaml"), {
        "glso": {"tasks": ["flat"], "seeds": [0], "budget": 9, "models": tiny_models, "bo": {"init": 2}, "rung": ""},
        "evaluation": {"mppi": {"samples": 2, "first_samples": 2, "horizon": 2, "episode": 2}},
        "compute": {"cache": ""}})))
    return str(path)


def test_cli_prints_a_json_line_per_step_and_the_best_design_last(params, tiny_models, capsys):
    model = tiny_models.format(variant="full")
    assert main(["glso", "--task", "flat", "--method", "glso", "--budget", "3", "--seed", "0", "--model", model,
                 "--params", params]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    steps, best = lines[:-1], lines[-1]["best"]
    assert [s["step"] for s in steps] == [0, 1, 2]
    assert set(steps[0]) == {"step", "design_id", "rules", "score", "status", "best_so_far"}
    simulated = [s for s in steps if s["status"] == "ok"]  # the best is a simulated design, never an invalid score
    assert best["score"] == steps[-1]["best_so_far"] == max(s["score"] for s in simulated)


@pytest.mark.parametrize("argv, message", [
    (["--method", "nelder_mead"], "--method: unknown method 'nelder_mead'"),
    (["--method", "mcts", "--model", "m.pt"], "--model: method mcts does not use a VAE"),
    (["--budget", "0"], "--budget: expected a positive number"),
    (["--task", "moon"], "moon"),
])
def test_cli_bad_input_exits_2_with_one_line(argv, message, params, capsys):
    assert main(["glso", "--params", params, *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


def test_cli_runs_the_search_on_a_dask_worker_and_prints_what_a_local_run_prints(params, capsys, dask_address):
    argv = ["glso", "--task", "flat", "--method", "random", "--budget", "3", "--params", params]
    assert main(argv) == 0
    local = capsys.readouterr().out
    assert main([*argv, "--address", dask_address]) == 0
    assert capsys.readouterr().out == local and len(local.splitlines()) == 4


def _search_argv(params, *extra):
    return ["glso", "--task", "flat", "--method", "random", "--budget", "3", "--params", params, *extra]


def test_cli_scores_at_glso_rung_when_one_is_named(params, tmp_path, capsys, monkeypatch):
    from pathlib import Path

    import yaml

    from robocompose.evaluation import fidelity
    from robocompose.evaluation.evaluate import EvaluationConfig
    from robocompose.fanout.cache import EvaluationCache

    monkeypatch.setitem(fidelity.LADDER, "tiny", (2, 2, 2, 3))
    document = yaml.safe_load(Path(params).read_text())
    document["glso"]["rung"], document["compute"]["cache"] = "tiny", str(tmp_path / "cache.parquet")
    Path(params).write_text(yaml.safe_dump(document))
    assert main(_search_argv(params)) == 0
    scored = EvaluationCache(tmp_path / "cache.parquet").frame()
    assert len(scored) > 0  # every design the run sent, at the rung's MPPI (not evaluation.mppi's)
    assert set(scored["settings_hash"]) == {EvaluationConfig(mppi=fidelity.rung_config("tiny")).settings_hash("flat")}


@pytest.mark.parametrize("out, message", [
    ("folder", "folder: is a directory, expected a file name ending in .parquet"),
    ("steps.csv", "steps.csv: expected a .parquet file name"),
    ("blocker/steps.parquet", "blocker is not a directory"),
])
def test_a_bad_out_path_fails_in_one_line_before_the_search_runs(out, message, params, tmp_path, capsys):
    (tmp_path / "folder").mkdir()
    (tmp_path / "blocker").write_text("a file")
    assert main(_search_argv(params, "--out", str(tmp_path / out))) == 2
    captured = capsys.readouterr()
    assert captured.out == ""  # no step ran: the path is checked first
    assert message in captured.err and len(captured.err.strip().splitlines()) == 1
    assert not (tmp_path / "steps.csv").exists()


def test_out_writes_the_step_table_as_parquet(params, tmp_path, capsys):
    from robocompose.io import read_table

    assert main(_search_argv(params, "--out", str(tmp_path / "steps.parquet"))) == 0
    steps = [json.loads(line) for line in capsys.readouterr().out.splitlines()[:-1]]
    assert list(read_table(tmp_path / "steps.parquet", "glso_steps")["design_id"]) == [s["design_id"] for s in steps]


class Marker:
    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        import os

        return os.system, (f"touch {self.path}",)


def test_a_crafted_pickle_as_checkpoint_does_not_run_and_gives_one_line(params, tmp_path, capsys):
    import pickle

    marker, crafted = tmp_path / "marker", tmp_path / "run.ckpt"
    crafted.write_bytes(pickle.dumps({"key": "whatever", "state": pickle.dumps(Marker(marker))}))
    assert main(_search_argv(params, "--checkpoint", str(crafted))) == 2
    captured = capsys.readouterr()
    assert not marker.exists() and captured.out == ""
    assert f"{crafted}: not a robocompose checkpoint" in captured.err and len(captured.err.strip().splitlines()) == 1


@pytest.mark.parametrize("kind", ["pickle", "json", "torch"])
def test_a_forged_checkpoint_with_this_runs_key_runs_nothing_and_gives_one_line(kind, params, tmp_path, capsys):
    """Issue 43: the key is no secret. Handed another run's checkpoint, the command names this run's key; it is
    also what run_key computes. A pickle with a command in its __reduce__, behind a header with that key and the
    payload's true hash (as the former pickle format, or claiming a torch or JSON payload), must not run from
    the loader, from a run it is named for, or from the command line: one line naming the file each time."""
    import hashlib
    import pickle
    import re

    from robocompose.evaluation.evaluate import EvaluationConfig
    from robocompose.glso.runs import GLSOConfig, RunSpec, run_key, run_search
    from robocompose.io import InputError
    from robocompose.io.checkpoint import load_checkpoint, save_checkpoint
    from robocompose.params import load_section

    marker, forged = tmp_path / "marker", tmp_path / "run.ckpt"
    argv = ["glso", "--task", "flat", "--method", "random", "--budget", "1", "--params", params,
            "--checkpoint", str(forged)]
    save_checkpoint(forged, "0" * 16, [], kind="json")  # another run's checkpoint
    assert main(argv) == 2
    key = re.search(r"this run's key ([0-9a-f]+)", capsys.readouterr().err).group(1)
    config = load_section(GLSOConfig, "glso", params)
    spec, config = RunSpec("flat", "random", 0), dataclasses.replace(config, budget=1)
    evaluation = load_section(EvaluationConfig, "evaluation", params)
    assert run_key(spec, config, evaluation, None) == key

    payload = pickle.dumps(Marker(marker))
    forged.write_bytes(f"robocompose-checkpoint {kind} {key} {hashlib.sha256(payload).hexdigest()}\n".encode()
                       + payload)
    with pytest.raises(InputError) as loaded:
        load_checkpoint(forged, key, named=True)
    with pytest.raises(InputError) as ran:
        run_search(spec, config, evaluation, objective_fn=lambda tree: pytest.fail("evaluated"), checkpoint=forged,
                   named_checkpoint=True)
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert not marker.exists() and captured.out == ""
    for line in (str(loaded.value), str(ran.value), captured.err.strip()):
        assert f"{forged}: " in line and "\n" not in line
    pickle.loads(payload)  # the control: unpickled, this payload does run its command
    assert marker.exists()


@pytest.mark.parametrize("kind", ["text", "directory", "under_a_file", "other_run"])
def test_a_checkpoint_that_is_not_this_runs_gives_one_line(kind, params, tmp_path, capsys):
    path = tmp_path / "run.ckpt"
    if kind == "text":
        path.write_text("not a checkpoint\n")
    elif kind == "directory":
        path.mkdir()
    elif kind == "under_a_file":
        path.write_text("a file")
        path = path / "run.ckpt"
    else:  # the checkpoint of seed 1 named for seed 0: refused, not overwritten
        assert main(_search_argv(params, "--seed", "1", "--checkpoint", str(path))) == 0
        capsys.readouterr()
    before = path.read_bytes() if path.is_file() else None
    assert main(_search_argv(params, "--checkpoint", str(path))) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.strip().splitlines()) == 1 and str(path) in captured.err
    assert (path.read_bytes() if path.is_file() else None) == before


def test_a_run_resumes_from_its_own_checkpoint(params, tmp_path, capsys):
    checkpoint = tmp_path / "run.ckpt"
    assert main(_search_argv(params, "--checkpoint", str(checkpoint))) == 0
    first = capsys.readouterr().out
    assert main(_search_argv(params, "--checkpoint", str(checkpoint))) == 0  # finished: nothing left to run
    assert capsys.readouterr().out == first.splitlines()[-1] + "\n"  # only the best line: no step was re-run
