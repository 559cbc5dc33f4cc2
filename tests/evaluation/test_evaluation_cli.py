import json

import pytest
import yaml

from robocompose.cli import main
from robocompose.io import read_mcap

RIDGED_BEST = "0,7,1,13,1,2,16,12,13,6,4,19,4,17,5,3,2,16,4,5,18,9,8,9,9,8"


def _params(tmp_path):
    path = tmp_path / "params.yaml"
    mppi = {"samples": 2, "first_samples": 2, "horizon": 2, "episode": 3}
    path.write_text(yaml.safe_dump({"evaluation": {"mppi": mppi, "seed": 0}}))
    return path


def test_evaluate_command_prints_the_row_and_writes_logs(tmp_path, capsys):
    code = main(["evaluate", "--rules", RIDGED_BEST, "--task", "ridged", "--params", str(_params(tmp_path)),
                 "--mcap", str(tmp_path / "r.mcap"), "--gif", str(tmp_path / "r.gif")])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["status"] == "ok" and out["task"] == "ridged" and out["seed"] == 0
    assert (tmp_path / "r.gif").exists() and len([m for m in read_mcap(out["mcap"]) if m.topic == "/tf"]) == 3


def test_bad_task_and_rules_exit_2_with_a_message(tmp_path, capsys):
    assert main(["evaluate", "--rules", RIDGED_BEST, "--task", "moon", "--params", str(_params(tmp_path))]) == 2
    assert "unknown task 'moon'" in capsys.readouterr().err
    assert main(["evaluate", "--rules", "0,7,x", "--params", str(_params(tmp_path))]) == 2
    assert "rule sequence item 2" in capsys.readouterr().err


@pytest.mark.parametrize(("flags", "fragments"), [
    (["--seed", "-1"], ["argument --seed", "expected an integer >= 0, found -1"]),
    (["--mcap", "folder"], ["argument --mcap", "folder: is a directory, expected a file name ending in .mcap"]),
    (["--gif", "run.png"], ["argument --gif", "run.png: expected a .gif file name"]),
    (["--params", "missing.yaml"], ["missing.yaml: params file not found"]),
])
def test_bad_flags_fail_before_any_simulation(tmp_path, monkeypatch, cli_error, flags, fragments):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "folder").mkdir()
    cli_error(["evaluate", "--rules", RIDGED_BEST, "--task", "flat", *flags], *fragments)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder"]


def test_unknown_task_is_reported_without_a_params_file(tmp_path, monkeypatch, cli_error):
    monkeypatch.chdir(tmp_path)  # no ./params.yaml here
    cli_error(["evaluate", "--rules", RIDGED_BEST, "--task", "moon"], "unknown task 'moon'", "known tasks")
