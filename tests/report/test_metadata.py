"""Run metadata: a report built by `dvc repro` from a clean tree shows a clean revision and every stage."""

import json
import subprocess

import pytest

from robocompose.report.metadata import section

DVC_YAML = """stages:
  make:
    cmd: python make.py
    deps: [make.py]
    outs: [data/made.txt]
    metrics:
      - reports/metrics/made.json:
          cache: false
  train:
    matrix:
      variant: [a, b]
    cmd: python train.py ${item.variant}
    deps: [train.py]
    outs:
      - reports/training/${item.variant}:
          cache: false
"""


@pytest.fixture
def project(tmp_path):
    from dvc.repo import Repo

    def git(*args):
        subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *args], cwd=tmp_path, check=True,
                       capture_output=True)

    git("init", "-q")
    Repo.init(str(tmp_path)).close()
    (tmp_path / "dvc.yaml").write_text(DVC_YAML)
    for name in ("make.py", "train.py", "params.yaml", "dvc.lock", "reports/metrics/made.json",
                 "reports/training/a/metrics.json", "reports/timings.json"):
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text("schema: '2.0'\nstages: {}\n" if name == "dvc.lock" else "{}\n")
    git("add", "-A")
    git("commit", "-qm", "start")
    return tmp_path


def test_outputs_dvc_writes_do_not_count_as_uncommitted(project):
    for name in ("dvc.lock", "reports/metrics/made.json", "reports/training/a/metrics.json"):
        (project / name).write_text((project / name).read_text() + "# rerun\n")  # as `dvc repro` leaves them
    (project / "reports/timings.json").write_text(json.dumps({"make": {"seconds": 1.5, "rows": 3}}))
    text = section(project / "reports", project / "params.yaml", project)
    assert "uncommitted" not in text and "- git revision: `" in text
    assert "| make | 1.5 | rows 3 |" in text
    assert "| train@a | not recorded | |" in text and "| train@b | not recorded | |" in text


def test_a_changed_source_or_params_is_named(project):
    (project / "train.py").write_text("changed = True\n")
    (project / "params.yaml").write_text("seed: 1\n")
    text = section(project / "reports", project / "params.yaml", project)
    assert "with uncommitted changes to `params.yaml`, `train.py`" in text
