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
    runs = [{"chip": "a", "seconds": 4.0}, {"chip": "b", "seconds": 9.0}, {"chip": "c", "seconds": 2.0}]
    (project / "reports/timings.json").write_text(json.dumps({"make": {"seconds": 1.5, "rows": 3, "runs": runs}}))
    text = section(project / "reports", project / "params.yaml", project)
    assert "uncommitted" not in text and "- git revision: `" in text
    assert "| make | 1.5 | rows 3, runs 3 runs (median seconds 4.0) |" in text
    assert "| train@a | not recorded | |" in text and "| train@b | not recorded | |" in text


def test_a_changed_source_or_params_is_named(project):
    (project / "train.py").write_text("changed = True\n")
    (project / "params.yaml").write_text("seed: 1\n")
    text = section(project / "reports", project / "params.yaml", project)
    assert "with uncommitted changes to `params.yaml`, `train.py`" in text


def _git(project, *args):
    subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *args], cwd=project, check=True,
                   capture_output=True)


def _commit_runs(project):
    """Two committed runs: run 1 (hidden 16, accuracy 0.5), then run 2 (hidden 32, accuracy 0.75)."""
    for hidden, accuracy, seconds in ((16, 0.5, 3.0), (32, 0.75, 5.0)):
        (project / "params.yaml").write_text(f"model:\n  hidden: {hidden}\nseed: 0\n")
        (project / "dvc.lock").write_text(f"schema: '2.0'\nstages: {{}}\n# hidden {hidden}\n")
        (project / "reports/metrics/made.json").write_text(json.dumps({"accuracy": accuracy, "count": 3,
                                                                       "seconds": seconds}))
        _git(project, "commit", "-qam", f"run {1 if hidden == 16 else 2}")


def test_the_previous_committed_run_its_changed_params_and_moved_metrics_are_shown(project):
    _commit_runs(project)
    (project / "README").write_text("a later commit that touches neither params.yaml nor dvc.lock\n")
    _git(project, "add", "README")
    _git(project, "commit", "-qm", "docs")
    text = section(project / "reports", project / "params.yaml", project)
    first = subprocess.run(["git", "rev-parse", "--short=7", "HEAD~2"], cwd=project, capture_output=True,
                           text=True, check=True).stdout.strip()
    assert "- dvc.lock sha256: `" in text
    assert f"- previous committed run: `{first} run 1` (1 params differ, 1 metrics moved" in text
    changes = text.split(f"### Changed since `{first}`")[1]
    assert "| `model.hidden` | 16 | 32 |" in changes and "`seed`" not in changes
    assert "| `reports/metrics/made.json: accuracy` | 0.5 | 0.75 |" in changes
    assert "seconds" not in changes and "count" not in changes  # wall times left out; unchanged metrics too


def test_without_an_earlier_run_the_report_says_so(project):
    text = section(project / "reports", project / "params.yaml", project)
    assert "- previous committed run: none" in text and "### Changed since" not in text


def test_the_metrics_diff_works_inside_a_running_dvc_repro(project, tmp_path):
    """The report stage runs `dvc metrics diff` while `dvc repro` runs it: DVC releases its repository lock
    while a stage's command runs, so the nested dvc call gets it."""
    import os
    import sys
    from pathlib import Path

    _commit_runs(project)
    (project / "params.yaml").write_text("model:\n  hidden: 64\nseed: 0\n")
    (project / "reports/metrics/made.json").write_text(json.dumps({"accuracy": 0.9, "count": 3}))
    (project / "report_stage.py").write_text(
        "from pathlib import Path\nfrom robocompose.report.metadata import changes_section\n"
        "Path('out.md').write_text('\\n'.join(changes_section(Path('params.yaml'))))\n")
    (project / "dvc.yaml").write_text(DVC_YAML + "  report:\n    cmd: python report_stage.py\n"
                                      "    deps: [report_stage.py, params.yaml]\n    outs: [out.md]\n")
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": str(root), "DVC_NO_ANALYTICS": "1",
           "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    done = subprocess.run([sys.executable, "-m", "dvc", "repro", "report"], cwd=project, env=env, capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    text = (project / "out.md").read_text()
    # Only this stage ran, so while it ran dvc.lock was still run 2's: the run it differs from is run 1.
    assert "run 1` (1 params differ, 1 metrics moved" in text
    assert "| `model.hidden` | 16 | 64 |" in text and "| `reports/metrics/made.json: accuracy` | 0.5 | 0.9 |" in text
