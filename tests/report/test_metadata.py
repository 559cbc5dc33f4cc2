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


def test_the_previous_committed_run_its_changed_params_and_moved_metrics_are_shown(project):
    def commit(params, lock, metrics, message):
        (project / "params.yaml").write_text(params)
        (project / "dvc.lock").write_text(lock)
        (project / "reports/metrics/made.json").write_text(json.dumps(metrics))
        subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qam", message], cwd=project,
                       check=True, capture_output=True)

    commit("model:\n  hidden: 16\nseed: 0\n", "schema: '2.0'\nstages: {}\n# run 1\n",
           {"accuracy": 0.5, "count": 3, "seconds": 3.0}, "run 1")
    commit("model:\n  hidden: 32\nseed: 0\n", "schema: '2.0'\nstages: {}\n# run 2\n",
           {"accuracy": 0.75, "count": 3, "seconds": 5.0}, "run 2")
    (project / "README").write_text("a later commit that touches neither params.yaml nor dvc.lock\n")
    subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", "add", "README"], cwd=project, check=True)
    subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "docs"], cwd=project,
                   check=True, capture_output=True)
    text = section(project / "reports", project / "params.yaml", project)
    first = subprocess.run(["git", "rev-parse", "--short=7", "HEAD~2"], cwd=project, capture_output=True,
                           text=True, check=True).stdout.strip()
    assert "- dvc.lock sha256: `" in text
    assert f"- previous committed run: `{first}" in text and "run 1`" in text
    assert "params changed since: `model.hidden` 16 -> 32" in text and "`seed`" not in text
    assert f"### Changed since `{first}`" in text
    assert "| `reports/metrics/made.json` | accuracy | 0.5 | 0.75 |" in text
    assert "seconds" not in text.split("### Changed since")[1] and "| count |" not in text


def test_without_an_earlier_run_the_report_says_so(project):
    text = section(project / "reports", project / "params.yaml", project)
    assert "- previous committed run: none" in text and "### Changed since" not in text
