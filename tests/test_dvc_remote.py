"""Sharing runs through a DVC remote: outputs pushed to a directory remote arrive in a fresh clone.

A collaborator who clones the repository and runs `dvc pull` gets the outputs of the committed
`dvc.lock` (trained models, tables) without re-running the pipeline, and `dvc status` is then clean.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

# A two-stage pipeline: `make` writes a "model" from params, `use` a table from it.
DVC_YAML = """\
stages:
  make:
    cmd: python -c "open('model.bin', 'wb').write(bytes(range(${n})) * 1000)"
    params: [n]
    outs: [model.bin]
  use:
    cmd: python -c "open('table.txt', 'w').write(str(len(open('model.bin', 'rb').read())))"
    deps: [model.bin]
    outs: [table.txt]
"""
ENV = {**os.environ, "DVC_NO_ANALYTICS": "1", "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@example.org",
       "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@example.org",
       "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}


def run(cwd: Path, *command: str) -> str:
    done = subprocess.run(command, cwd=cwd, env=ENV, capture_output=True, text=True)
    assert done.returncode == 0, f"{' '.join(command)}: {done.stdout}\n{done.stderr}"
    return done.stdout


def dvc(cwd: Path, *args: str) -> str:
    return run(cwd, sys.executable, "-m", "dvc", *args)


def test_outputs_pushed_to_a_directory_remote_are_pulled_into_a_fresh_clone(tmp_path: Path) -> None:
    origin, remote, clone = tmp_path / "origin", tmp_path / "remote", tmp_path / "clone"
    origin.mkdir()
    (origin / "dvc.yaml").write_text(DVC_YAML)
    (origin / "params.yaml").write_text("n: 200\n")
    run(origin, "git", "init", "-q")
    dvc(origin, "init", "-q")
    dvc(origin, "remote", "add", "-d", "shared", str(remote))  # as the README sets it up
    dvc(origin, "repro")
    run(origin, "git", "add", "-A")
    run(origin, "git", "commit", "-qm", "pipeline run")
    dvc(origin, "push")
    assert any(remote.rglob("*")), "the push wrote nothing to the remote"

    run(tmp_path, "git", "clone", "-q", str(origin), str(clone))
    assert not (clone / "model.bin").exists()
    assert "changed outs" in dvc(clone, "status") or "deleted" in dvc(clone, "status")
    dvc(clone, "pull")
    assert (clone / "model.bin").read_bytes() == (origin / "model.bin").read_bytes()
    assert (clone / "table.txt").read_text() == "200000"
    assert "up to date" in dvc(clone, "status")
    assert "didn't change" in dvc(clone, "repro")  # nothing to re-run: the collaborator has the results
