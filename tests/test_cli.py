"""The `robocompose` entry: bad input is one line and exit code 2; a bug is not hidden."""

import pytest

from robocompose.cli import main


def test_profile_outside_the_repository_says_where_to_run_it(tmp_path, monkeypatch, cli_error):
    monkeypatch.chdir(tmp_path)
    line = cli_error(["profile", "default"], "run `robocompose profile` in the repository's root folder")
    assert line.startswith("robocompose: error: ") and not (tmp_path / "params.yaml").exists()


def test_unknown_profile_lists_the_known_ones(tmp_path, monkeypatch, cli_error):
    (tmp_path / "profiles").mkdir()
    (tmp_path / "profiles" / "default.yaml").write_text("enumerate: {n: 3}\n")
    monkeypatch.chdir(tmp_path)
    cli_error(["profile", "huge"], "profile 'huge': no such profile; expected one of ['default']")
    (tmp_path / "dvc.yaml").write_text("stages: {}\n")
    cli_error(["profile", "../dvc"], "profile '../dvc': no such profile; expected one of ['default']")
    assert not (tmp_path / "params.yaml").exists()


def test_a_misspelt_key_of_a_profile_fails_before_params_yaml_is_written(tmp_path, monkeypatch, cli_error):
    import shutil
    from pathlib import Path

    shutil.copytree(Path(__file__).resolve().parents[1] / "profiles", tmp_path / "profiles")
    (tmp_path / "profiles" / "mine.yaml").write_text("glso: {budjet: 3}\n")
    monkeypatch.chdir(tmp_path)
    cli_error(["profile", "mine"], "mine.yaml merged onto default.yaml: glso.budjet: unknown field")
    assert not (tmp_path / "params.yaml").exists()


def test_argparse_errors_exit_2_too(cli_error):
    cli_error(["no-such-command"], "invalid choice")


def test_only_input_errors_become_a_message(monkeypatch):
    def broken(args):
        raise KeyError("a bug")

    monkeypatch.setattr("robocompose.params.write_profile", broken)
    with pytest.raises(KeyError):
        main(["profile", "default"])


def test_the_program_pins_the_cpu_dispatch_before_it_runs_a_command(monkeypatch):
    import robocompose.cli
    import robocompose.io.dispatch

    calls = []
    monkeypatch.setattr(robocompose.io.dispatch, "pin_dispatch", lambda: calls.append("pin"))
    monkeypatch.setattr(robocompose.cli, "main", lambda: calls.append("main") or 0)
    assert robocompose.cli.run() == 0 and calls == ["pin", "main"]
