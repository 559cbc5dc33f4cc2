import json
import subprocess
import sys

import pytest

from robocompose.cli import main


def test_derive_prints_design(capsys, reference_rules):
    assert main(["derive", "--rules", reference_rules]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["complete"] is True and out["n_links"] >= 11 and len(out["design_id"]) == 16


@pytest.mark.parametrize(("rules", "step"), [("0,7,25", "step 2"), ("0,7,7", "step 2"), ("0,7,1", "incomplete")])
def test_derive_bad_sequence_exits_nonzero_naming_the_step(capsys, rules, step):
    assert main(["derive", "--rules", rules]) == 2
    assert step in capsys.readouterr().err


def test_enumerate_writes_parquet(tmp_path, capsys):
    out = tmp_path / "d.parquet"
    assert main(["enumerate", "--n", "3", "--seed", "0", "--out", str(out), "--workers", "1"]) == 0
    assert out.exists() and json.loads(capsys.readouterr().out)["kept"] == 3


@pytest.mark.parametrize(("flags", "fragments"), [
    (["--n", "-4"], ["argument --n", "expected an integer >= 1, found -4"]),
    (["--n", "2", "--seed", "-1"], ["argument --seed", "expected an integer >= 0, found -1"]),
    (["--n", "2", "--workers", "-1"], ["argument --workers", "expected an integer >= 0"]),
])
def test_enumerate_bad_numbers_fail_without_output(tmp_path, cli_error, flags, fragments):
    out = tmp_path / "d.parquet"
    cli_error(["enumerate", *flags, "--out", str(out)], *fragments)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("command", "out", "fragments"), [
    ("enumerate", "out.csv", ["argument --out", "out.csv: expected a .parquet file name (it is written as parquet)"]),
    ("enumerate", "folder", ["argument --out", "folder: is a directory, expected a file name ending in .parquet"]),
    ("render", "x.jpg", ["argument --out", "x.jpg: expected a .png file name (it is written as PNG)"]),
    ("render", "folder", ["argument --out", "is a directory"]),
    ("export-urdf", "folder", ["argument --out", "is a directory, expected a file name ending in .urdf"]),
    ("export-urdf", "robot.xml", ["argument --out", "expected a .urdf file name"]),
])
def test_outputs_are_checked_before_any_work(tmp_path, cli_error, monkeypatch, command, out, fragments):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "folder").mkdir()
    work = ["--n", "2"] if command == "enumerate" else ["--rules", "0,7,1,13,1,2,16,12,13,6,4,19,4,17,5,3,2,16,4,5,"
                                                                     "18,9,8,9,9,8"]
    cli_error([command, *work, "--out", out], *fragments)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder"] and not any((tmp_path / "folder").iterdir())


def test_help_does_not_import_torch_or_pybullet():
    code = ("import sys; from robocompose.cli import parser; parser(); "
            "print('torch' in sys.modules, 'pybullet' in sys.modules)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.split() == ["False", "False"]
