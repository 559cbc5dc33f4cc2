"""The `robocompose` entry: bad input is one line and exit code 2 (argparse's errors too, and after pybullet is
loaded); Ctrl-C is one line and exit code 130; a bug is not hidden."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from robocompose.cli import main
from robocompose.grammar.references import REFERENCE_DESIGNS

ROOT = Path(__file__).resolve().parents[1]


def _terminal_sigint() -> None:
    """SIGINT as a terminal's Ctrl-C finds it: the default action. A child inherits an ignored SIGINT (and Python
    then installs no KeyboardInterrupt): a suite started as a background job of a script (`make test-slow &`)
    ignores it, so the command never saw the test's Ctrl-C and the test waited out its timeout."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _robocompose(*argv: str, cwd: Path, **options) -> subprocess.Popen:
    """`python -m robocompose.cli ARGV` in its own session (a Ctrl-C reaches its whole process group), with SIGINT
    as in a terminal."""
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    return subprocess.Popen([sys.executable, "-m", "robocompose.cli", *argv], cwd=cwd, env=environment, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
                            preexec_fn=_terminal_sigint, **options)


def _kill_group(pgid: int) -> None:
    try:
        os.killpg(pgid, signal.SIGKILL)
    except ProcessLookupError:  # every member has ended
        pass


def _group(pgid: int) -> list[int]:
    """The processes of process group `pgid` (from /proc)."""
    members = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:  # ended meanwhile
            continue
        if int(fields[2]) == pgid:  # after the name: state, ppid, pgrp
            members.append(int(stat.parent.name))
    return members


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


def test_argparse_errors_of_a_sub_command_are_one_line_without_usage(cli_error):
    line = cli_error(["compose", "modular", "--terrain-seed", "1", "--k", "0"])
    assert line == "robocompose: error: argument --k: expected an integer >= 1, found 0"


def test_help_still_prints_the_usage_block(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["render", "--help"])
    assert exit_.value.code == 0 and capsys.readouterr().out.startswith("usage: robocompose render")


def test_a_long_message_is_cut_keeping_its_start():
    from robocompose.io.errors import LINE_LIMIT, InputError, error_line

    line = error_line("robocompose", InputError("--task 'x': " + "y" * 1000))
    assert line.startswith("robocompose: error: --task 'x': yyy") and line.endswith("...")
    assert len(line) == len("robocompose: error: ") + LINE_LIMIT
    assert error_line("p", InputError("short\n  two lines")) == "p: error: short; two lines"


def test_the_pybullet_banner_does_not_come_before_the_error_line(tmp_path):
    """The flat reference design is derived, pybullet is imported (its C banner goes to /dev/null), then the task
    is rejected: stderr holds the one error line and nothing else."""
    process = _robocompose("evaluate", "--rules", REFERENCE_DESIGNS["robogrammar_flat"], "--task", "nowhere",
                           cwd=tmp_path)
    out, err = process.communicate(timeout=300)
    assert process.returncode == 2 and out == ""
    assert err.splitlines() == ["robocompose: error: unknown task 'nowhere'; known tasks: "
                                "['flat', 'frozen_lake', 'ridged', 'wall']"], err


def test_pybullet_loads_quietly_and_output_still_works(tmp_path):
    code = ("import os, sys; from robocompose.io.quiet import quiet_pybullet; quiet_pybullet(); import pybullet as pb; "
            "print('out'); print('err', file=sys.stderr); os.write(2, b'fd2\\n'); print(pb.DIRECT == pb.DIRECT)")
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", code], env=environment, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout == "out\nTrue\n" and done.stderr == "err\nfd2\n", done


@pytest.mark.slow  # a real command is interrupted after 4 s
def test_ctrl_c_is_one_line_exit_130_and_leaves_the_output_as_it_was(tmp_path):
    """A Ctrl-C (SIGINT to the process group: the command and its workers) while enumerate works: exit code 130,
    `robocompose: interrupted` as the last line, no traceback (the progress bars before it are the command's own),
    the output file that was there untouched."""
    (tmp_path / "X.parquet").write_bytes(b"an earlier table")
    process = _robocompose("enumerate", "--n", "100000", "--out", "X.parquet", "--workers", "2", cwd=tmp_path)
    try:
        # The Ctrl-C comes once the two workers are up (the command, the forkserver and the workers share its process
        # group), not after a fixed wait: on a busy machine that can land in their start-up, not what this is about.
        deadline = time.monotonic() + 60
        while len(_group(process.pid)) < 4 and time.monotonic() < deadline:
            assert process.poll() is None, process.communicate()
            time.sleep(0.2)
        time.sleep(2)
        assert process.poll() is None, process.communicate()
        ignored = int(next(line for line in Path(f"/proc/{process.pid}/status").read_text().splitlines()
                           if line.startswith("SigIgn:")).split()[1], 16)
        assert not ignored & 1 << (signal.SIGINT - 1)  # the Ctrl-C below reaches a process that takes it
        os.killpg(process.pid, signal.SIGINT)
        out, err = process.communicate(timeout=120)
    finally:  # a failed check or a timeout leaves no enumeration computing in the background
        _kill_group(process.pid)
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith("enumerate: ")]
    assert process.returncode == 130 and out == "", err
    assert lines == ["robocompose: interrupted"] and err.rstrip().endswith("robocompose: interrupted"), err
    assert (tmp_path / "X.parquet").read_bytes() == b"an earlier table"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["X.parquet"]  # no temporary file left


def test_ctrl_c_in_a_command_returns_130_with_one_line(monkeypatch, capsys):
    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr("robocompose.params.write_profile", interrupted)
    assert main(["profile", "default"]) == 130
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == "robocompose: interrupted\n"


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
